"""Sensor programs (``navd sensor KIND``): read a device, stream to navd over TCP."""
