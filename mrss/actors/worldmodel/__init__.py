"""The World Model: objects in a store (SQLite or PostGIS), project rules, an HTTP API."""
