"""File formats: runs files, encoder logs, bags, parameter export."""
