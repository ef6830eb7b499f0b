"""The API's routes, a router per module: layouts.py (the jobs, /v1/layouts),
validate.py (/v1/validate) and health.py (/healthz, /readyz)."""
