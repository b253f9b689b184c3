"""Animations: frames and pixel mappings, per-frame lights, the lighting tensor, tensor clustering."""
