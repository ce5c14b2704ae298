"""Closed-form physics shared by the elements and the analyses: impact-force estimates, restitution."""
