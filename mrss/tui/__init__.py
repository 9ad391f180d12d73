"""The Textual monitoring and debug dashboard of a running MRSS system (`mrss tui PROJECT`).

See docs/tui.md. `mrss.tui.app.MrssApp` is the app; `mrss.tui.discovery` finds a running
system's bus; the panels are in `mrss.tui.widgets`, what they show in `mrss.tui.models`.
"""
