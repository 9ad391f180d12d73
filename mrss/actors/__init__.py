"""The components of the architecture, one package each, independent of one another.

Each package holds its component's service (the class the root supervisor starts, named in
project.toml by kind: see mrss.runtime.kinds), its core, and everything only it uses."""
