"""Benchmarks behind ``navd bench``: each prints the figures an issue asks for."""
