"""Snapshots of a running episode: break at a state, write the world to a file, resume it."""
