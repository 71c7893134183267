"""Layered Bragg structures: the single-reflection model (numpy twin), its GPU engine and the
position-free Monte Carlo reference."""
