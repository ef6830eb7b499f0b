"""The floorplan service, in layers; each imports only from the layers below it:

    cli/        the `floorplan` command (`python -m floorplan.service`): solve, serve, worker
    api/        the HTTP API: the app, its routes, dependencies, wire types, errors,
                the web page
    jobs/       where jobs are solved: the backend interface, the embedded backend,
                the Celery backend and workers (celery/), the solve processes
    settings.py, records.py, store/, migrations/
                the settings, the job records and their store
"""
