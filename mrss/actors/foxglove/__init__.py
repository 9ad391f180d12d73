"""The Foxglove component: the live bus as a Foxglove WebSocket server, with the channels
and schemas of an MCAP recording (docs/foxglove.md)."""
