"""Wavelet precomputed radiance transfer (Ng, Ramamoorthi & Hanrahan 2003): `realtime.diffuse = "wavelet_prt"`."""
