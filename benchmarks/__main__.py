"""Run every benchmark module of this package in turn."""
import importlib
import pkgutil

import benchmarks

for info in sorted(pkgutil.iter_modules(benchmarks.__path__), key=lambda m: m.name):
    if info.name.startswith("_"):
        continue
    mod = importlib.import_module(f"benchmarks.{info.name}")
    if hasattr(mod, "main"):
        print(f"\n=== {info.name} ===")
        mod.main()
