"""What the dashboard knows of the system, built from bus messages (no Textual here)."""
