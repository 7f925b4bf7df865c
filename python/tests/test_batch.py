"""`aerorect.batch`: the facade's batch run, so every frame is `aerorect batch`'s file byte for
byte; an existing whole output is skipped and reported; option errors name the keyword where
the CLI names the flag."""

from __future__ import annotations

import pytest

import aerorect
from conftest import cli_error, photo, run


def test_batch_frames_are_the_cli_bytes(tmp_path, cli):
    photos = [photo(tmp_path, f"f{k}.jpg", lat=53.9 + k * 1e-4, yaw=10.0 * k, pitch=-70.0 - 5 * k)
              for k in range(3)]
    r = aerorect.batch(photos, tmp_path / "py", gsd_m=0.2, jobs=2, interp="bicubic")
    run(cli, "batch", *photos, "--out-dir", tmp_path / "cli", "--gsd-m", "0.2",
        "--interp", "bicubic")
    assert [f["status"] for f in r["frames"]] == ["done"] * 3
    assert [f["input"] for f in r["frames"]] == [str(p) for p in photos]
    for k in range(3):
        py = (tmp_path / "py" / f"f{k}.tif").read_bytes()
        assert py == (tmp_path / "cli" / f"f{k}.tif").read_bytes()
        assert r["frames"][k]["report"]["output"] == str(tmp_path / "py" / f"f{k}.tif")
    # Run again: every frame is whole, so every frame is skipped, as the CLI says.
    again = aerorect.batch(photos, tmp_path / "py", gsd_m=0.2)
    assert [f["status"] for f in again["frames"]] == ["skipped"] * 3
    # The library's advice names the option as each front end spells it.
    assert again["frames"][0]["why"] == f"{tmp_path / 'py' / 'f0.tif'} exists (use force to rewrite)"
    cli_again = run(cli, "batch", *photos, "--out-dir", tmp_path / "cli", "--gsd-m", "0.2")
    assert (f"{tmp_path / 'cli' / 'f0.tif'} exists (use --force to rewrite)"
            in cli_again.stdout + cli_again.stderr)


@pytest.mark.parametrize("kwargs,flags,key,flag", [
    (dict(gsd_m=-1.0), ["--gsd-m=-1"], "gsd_m=-1", "--gsd-m -1"),
    (dict(vertical_offset_m=1e300), ["--vertical-offset-m", "1e300"],
     "vertical_offset_m=1e300", "--vertical-offset-m 1e300"),
    (dict(jobs=0), ["--jobs", "0"], "jobs=0", "--jobs 0"),
])
def test_option_errors_name_the_keyword_where_the_cli_names_the_flag(tmp_path, cli, kwargs,
                                                                        flags, key, flag):
    p = photo(tmp_path, "a.jpg")
    with pytest.raises(aerorect.AerorectError) as e:
        aerorect.batch([p], tmp_path / "py", **kwargs)
    got = cli_error(run(cli, "batch", p, "--out-dir", tmp_path / "cli", *flags, ok=False))
    assert got.startswith(flag + ": ")
    # The same message with the front end's own spelling of the option.
    assert str(e.value) == key + got[len(flag):]
    assert not (tmp_path / "py").exists() and not (tmp_path / "cli").exists()
