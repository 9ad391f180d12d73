"""Operators: who they are (the identity store), what each role may do, and the session
credentials that carry an operator's identity with every command (docs/tui.md, "Roles")."""
