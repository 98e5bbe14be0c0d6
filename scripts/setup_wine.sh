#!/usr/bin/env bash
# What the Windows kernel test (tests/core/test_kernel_platforms.py) needs: Debian's 64-bit Wine, pinned (Debian 12's
# own version), to run the cross-compiled Windows x64 kernel. Without root and apt the test is skipped.
set -euo pipefail
WINE_VERSION="8.0~repack-4"
if [ ! -x /usr/lib/wine/wine64 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq
        apt-get install -y -qq --no-install-recommends "wine64=$WINE_VERSION" "libwine=$WINE_VERSION" >/dev/null
    else
        echo "warning: /usr/lib/wine/wine64 is missing and installing it needs root and apt-get; the Windows kernel" \
            "test is skipped" >&2
    fi
fi
