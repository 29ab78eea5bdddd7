"""Sensors: wheel/steering encoders, the rotating laser goniometer, ultrasonic rangers."""
