"""Simulated robots speaking real protocols: a MAVLink UAV and an MQTT UGV."""
