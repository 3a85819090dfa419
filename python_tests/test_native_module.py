# SPDX-License-Identifier: GPL-3.0-or-later
import texsynth_native


def test_module_imports_and_reports_version():
    assert texsynth_native.__version__.count(".") == 2


def test_cache_error_is_a_value_error():
    assert issubclass(texsynth_native.CacheError, ValueError)
