"""Robot links: MAVLink and MQTT connections the RCL uses to command robots."""
