"""The planning service: FastAPI app, request limits, metrics (verification jobs come next)."""
