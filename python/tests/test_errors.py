"""Error classes: a file that cannot be read raises `AerorectFileError` (an `OSError`), a bad value
raises `AerorectError` (a `ValueError`); both carry the CLI's message."""

from __future__ import annotations

import pytest

import aerorect
from conftest import cli_error, photo, run


def test_file_error_is_an_os_error():
    assert issubclass(aerorect.AerorectFileError, OSError)
    assert issubclass(aerorect.AerorectError, ValueError)
    assert not issubclass(aerorect.AerorectFileError, ValueError)


def test_missing_input_raises_os_error(tmp_path, cli):
    missing = tmp_path / "no_such_photo.jpg"
    with pytest.raises(OSError) as e:
        aerorect.rectify_photo(str(missing))
    assert isinstance(e.value, aerorect.AerorectFileError)
    assert not isinstance(e.value, ValueError)
    assert "no_such_photo.jpg" in str(e.value)
    got = run(cli, "rectify", str(missing), str(tmp_path / "o.tif"), ok=False)
    assert str(e.value) == cli_error(got)


def test_missing_metadata_file_raises_os_error(tmp_path):
    with pytest.raises(aerorect.AerorectFileError, match="no_such_photo.jpg"):
        aerorect.read_photo_metadata(str(tmp_path / "no_such_photo.jpg"))


def test_bad_value_raises_value_error(tmp_path):
    p = photo(tmp_path, "frame.jpg")
    with pytest.raises(ValueError) as e:
        aerorect.rectify_photo(str(p), gsd_m=-1.0)
    assert isinstance(e.value, aerorect.AerorectError)
    assert not isinstance(e.value, OSError)
