"""The Symbol and Data Layer (paper IV-C): grounding, external functions, telemetry."""
