"""The ASCCbot as hardware: its robot description and the bring-up's helpers."""
