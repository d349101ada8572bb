"""The project's LeafSystems, one per module."""
