"""HTTP service for the dynamics library: FastAPI app, robot store, simulation workers, Python client.

Kept import-light: importing the package (or ``service.client``) pulls in neither FastAPI nor the library, and no
module of the server imports the library at its top (see :mod:`service.library`).
"""

__version__ = "0.1.0"
