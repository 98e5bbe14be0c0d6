"""Benchmarks behind the README's tables: accuracy against MakeHuman's sculpted expressions (`evaluate`),
speed against Blender's Surface Deform (`bench`), the live handler (`bench_handler`) and the `.fap`
reader (`bench_fap_reader`). `bash scripts/run_benchmarks.sh` runs them all."""
