"""The dashboard over a recording (`mrss tui --replay FILE`): the tape, its index for
seeking, the player's cursor, and the link that feeds the dashboard's intake."""
