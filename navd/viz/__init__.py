"""The live view: what navd thinks, streamed to Foxglove or Lichtblick while it runs (an edge
room, like drivers: it listens to the bus and never reaches into the other rooms)."""
