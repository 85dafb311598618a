"""The simulator: a robot that speaks the real protocols (the chassis pty and TCP sensors)."""
