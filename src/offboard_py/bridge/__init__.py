"""The mavros-compatible bridge: one module per mavros plugin; node.py assembles them."""
