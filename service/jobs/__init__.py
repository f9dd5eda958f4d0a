"""Jobs: work too long for a request (thousands of simulations, millions of states), durable across crashes.

:mod:`.db` the records (SQLite), :mod:`.files` the inputs, parts and results on disk, :mod:`.runner` one job
run part by part by the library, :mod:`.executor` the worker processes and the dispatcher, :mod:`.manager`
what the routes (:mod:`service.routes.jobs`) call.
"""
