"""The package version, in a module of its own so that modules the package
__init__ imports (_kernel_cache, the history writer) read it without
importing the package itself."""
__version__ = "0.1.0"
