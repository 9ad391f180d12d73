"""Recordings of the bus: the file format, the recorder (mrss record, the dashboard)."""
