"""What runs beside the stack, not in it: the takeoff demo (demo), and the benchmark's and the
soak's helpers (streamstats, hover_phases, soak_rules). Nothing in the node, the bridge or the
simulator imports from here."""
