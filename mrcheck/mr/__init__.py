"""Mixed reality: calibration, markers, registration, lens geometry, photo overlay."""
