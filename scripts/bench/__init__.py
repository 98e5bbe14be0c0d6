"""Benchmarks behind the README's tables: accuracy against MakeHuman's sculpted expressions (`evaluate`),
speed against Blender's Surface Deform (`bench`) and the `.fap`
reader (`bench_fap_reader`). `bash scripts/run_benchmarks.sh` runs them all."""
