"""The web player's tooling: the exported sample (`sample_glb`), a static server (`serve`) and the headless
Chromium driver (`browser`, around `web/shoot.mjs`)."""
