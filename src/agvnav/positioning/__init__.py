"""positioning."""
