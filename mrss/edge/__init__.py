"""The edges of MRSS: what connects the outside world to the bus.

Predicate building, the MQTT client helper, payload schemas, the world model store and
its HTTP API, and the base classes project adapters subclass (`mrss.edge.adapters`).
The components themselves live in `mrss.actors.events`, `.datalayer` and `.worldmodel`.
"""
