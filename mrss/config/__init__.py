"""project.toml: one loader, the validated project as data, and each of its tables."""
