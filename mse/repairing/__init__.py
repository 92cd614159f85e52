"""Repairing a proposed expression into the nearest consistent timeline (docs/repair.md)."""
