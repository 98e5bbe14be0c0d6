"""Skip markers shared by the test packages: what a test needs that a machine may lack."""

import pytest

from addon.speech import espeak


def _espeak_missing() -> str | None:
    try:
        espeak._get_engine()
    except espeak.EspeakMissingError as exc:
        return str(exc)
    return None


_ESPEAK_MISSING = _espeak_missing()
needs_espeak = pytest.mark.skipif(_ESPEAK_MISSING is not None, reason=f"espeak-ng: {_ESPEAK_MISSING}")
