"""What every side of the distributed mode shares about the broker (Redis and Celery):
its configuration and keys (`config`), and the executor that sends a solve's
sub-domains to the sub-domain workers (`subdomains`). It knows nothing of the Celery
backend, the workers' runtime or the solve processes, so the solve child can use it."""
