"""Motor primitives: learners (PI² and others), the primitive library and interpolation."""
