"""The web player's tooling: the stand-in `.glb` (`make_test_glb`), a static server (`serve`) and the headless
Chromium driver (`browser`, around `web/shoot.mjs`)."""
