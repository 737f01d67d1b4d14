"""Generated JSON Schemas of the machine and scenario languages."""
