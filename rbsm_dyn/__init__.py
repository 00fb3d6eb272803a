"""rbsm_dyn: Kawai rigid-body-spring model, explicit dynamics."""
__version__ = "0.1.0"
