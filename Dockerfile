# The floorplan service: one image for API nodes (the default command) and Celery
# workers (`floorplan worker`); see docker-compose.yml. SCIP and GEOS come inside the
# pyscipopt and shapely wheels, so the slim image needs nothing from apt.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1

WORKDIR /app
COPY pyproject.toml README.md alembic.ini ./
# The dependencies first, in a layer of their own that only pyproject.toml changes: a
# change to the code alone then rebuilds in seconds, not minutes.
RUN python -c "import tomllib; p = tomllib.load(open('pyproject.toml', 'rb'))['project']; \
print('\n'.join(p['dependencies'] + p['optional-dependencies']['distributed']))" \
      > /tmp/requirements.txt \
 && pip install -r /tmp/requirements.txt && rm /tmp/requirements.txt
COPY models ./models
COPY solver ./solver
COPY service ./service
# service/api/examples links here: the web page serves the example problems.
COPY examples ./examples
RUN pip install ".[distributed]"

# Not root: Celery warns against it, and a solve has no business writing outside /data.
RUN useradd --create-home --uid 10001 floorplan && mkdir /data && chown floorplan /data
USER floorplan
ENV FLOORPLAN_DATA_DIR=/data \
    FLOORPLAN_HOST=0.0.0.0
# No VOLUME: the Celery-mode containers never write /data, and a declared volume would
# give each of them an anonymous one that outlives `docker compose down -v`. The embedded
# mode keeps its jobs across containers with a named volume: -v floorplan-data:/data.
EXPOSE 8000

# The embedded mode by default (`docker run -p 127.0.0.1:8000:8000 -v floorplan-data:/data
# floorplan`); compose sets FLOORPLAN_BACKEND=celery and runs workers from the same image.
CMD ["floorplan", "serve", "--host", "0.0.0.0", "--port", "8000"]
