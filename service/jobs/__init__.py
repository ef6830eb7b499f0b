"""Where accepted jobs go to be solved: one job-backend interface, two implementations.

The HTTP API only talks to a `JobBackend` (backend.py). `EmbeddedBackend` (embedded.py)
solves in child processes of the API's own process (the default, no other server);
`CeleryBackend` (celery/backend.py) hands jobs to Celery workers on other processes or
machines through Redis, with the records in PostgreSQL; `make_backend` (factory.py)
picks one. Either way a solve runs in its own spawned process (child.py) under the same
watchdog (processes.py).

Imports point down: factory.py -> embedded.py and celery/backend.py -> backend.py;
celery/runtime.py -> processes.py -> child.py -> broker/subdomains.py, which needs only
broker/config.py. backend.py, the interface, knows none of the implementations.
"""
