"""Benchmarks of the relay (``make bench``): each writes bench/results/<name>.json and docs/benchmarks.md.

Run everything with ``python -m bench.run`` (``--quick`` for the development subset); see docs/benchmarks.md.
"""
