"""What comes from outside MRSS, checked at the door: robot records and payload schemas,
the validation layer, refusals counted and reported, the MQTT client, retry rules and the
HTTP API's token. The components that use them live in `mrss.actors`."""
