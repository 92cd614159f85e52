"""Typed motion leaves: BVH I/O, LMA features, motion generation."""
