"""Actuators: steering servo, traction speed profile, motors with PID speed loops."""
