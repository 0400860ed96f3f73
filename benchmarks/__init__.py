"""Benchmarks of Robotics II Lab. Run all with ``python -m benchmarks``, one with
``python -m benchmarks.NAME``. Each module has ``main()`` printing a small table; speeds are ratios
against a baseline measured in the same process."""
