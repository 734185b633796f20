"""Mapping (RBPF), localization (MCL) and navigation (grid planner + controller) stand-ins."""
