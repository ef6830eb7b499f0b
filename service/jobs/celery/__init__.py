"""The distributed mode: API nodes and Celery workers, Redis as broker and pub/sub, job
records in PostgreSQL (or any store URL; the schema is the embedded store's).

A job's life here:

- An API node commits the job (it is accepted: 202), then sends a Celery task naming
  it and marks it dispatched. If the broker is down, the job stays undispatched and the
  reconciler sends it later.
- A worker receives the task, claims the job in the store (a conditional update: a
  duplicate delivery finds it no longer queued and does nothing), and solves it in a
  spawned child process under the same watchdog as the embedded mode
  (`service.jobs.processes.watch`). Tasks are acknowledged late, after the job ended.
- While solving, the worker renews its lease on the job every few seconds and reads
  the job's cancel flag; a cancel also arrives at once over Redis pub/sub. Every event
  it writes is announced on a Redis channel, on which API nodes wake their event
  streams (they poll the store as well, so a lost announcement only delays).
- The reconciler, a thread in every API node and worker, puts back in the queue the
  running jobs whose lease expired (their worker died: SIGKILL, power, partition) and
  sends again the queued jobs the broker does not have: never sent, or lost when Redis
  restarted without its data (a marker key tells: Redis lost it too).
- A worker stopped gracefully (SIGTERM) kills its solves and hands their jobs back to
  the queue at once, without counting an attempt.

Workers use Celery's `threads` pool: the solve runs in its own process anyway, and a
thread that watches it keeps the worker light.

With FLOORPLAN_SUBDOMAINS=celery, the independent sub-domains of a refinement level go
out as Celery tasks (`CelerySubdomains`, a `concurrent.futures.Executor` the solver
takes) to sub-domain workers (`floorplan worker --subdomains`), which consume a queue of
their own with Celery's prefork pool: each sub-domain is solved in a pool process under
Celery's hard time limit. Their results come back through Celery's Redis result backend.

The Celery configuration, the Redis names and the sub-domain executor (all a solve's
process needs) are in `service.jobs.broker`. The modules here, each importing only
those above it in this list: dispatch.py (sending jobs, reconciling), backend.py (the API node's
side), runtime.py (a worker process's side), worker.py (the Celery application, its
tasks and signals: `celery -A floorplan.service.jobs.celery.worker worker`).
"""
