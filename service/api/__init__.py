"""The HTTP API: asynchronous layout jobs (submit, follow, fetch, cancel, delete, list),
validation without solving, health, and the web page. Routes validate, delegate and
reply; solving is the job backend's (service/jobs/), geometry the solver's.

app.py builds the application from routes/ (a router per module) and web.py (the page,
its static files, the examples), with deps.py (what routes depend on), body.py (the
problem a request carries), schemas.py (the response bodies) and errors.py (RFC 9457
problem documents).
"""
