"""The world: reflector and wall maps, scenarios."""
