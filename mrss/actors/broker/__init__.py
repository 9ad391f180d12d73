"""The embedded MQTT broker component, its passwords and its persistent sessions."""
