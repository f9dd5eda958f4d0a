"""HTTP service for the dynamics library: FastAPI app, robot store, Python client.

Kept import-light: ``service.client`` and ``service.simworker`` must not pull in FastAPI or numba just by
importing the package.
"""

__version__ = "0.1.0"
