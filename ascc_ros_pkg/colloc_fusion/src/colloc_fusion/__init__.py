"""colloc_fusion: collaborative target localization with three robots (thesis chapter 3)."""
