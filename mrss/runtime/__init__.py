"""What every component process stands on: its context and base class, its entry point,
the kinds of component project.toml names, its bus port, and the root's remote control."""
