"""Drivers for the bench instruments, their typed errors and the bench description."""
