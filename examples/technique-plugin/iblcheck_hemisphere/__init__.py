"""Hemisphere lighting as an iblcheck technique plugin (`realtime.diffuse = "hemisphere"`)."""
