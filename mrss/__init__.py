"""MRSS: a multi-robot support system for disaster response."""

__version__ = "0.1.0"
