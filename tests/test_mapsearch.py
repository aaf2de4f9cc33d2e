"""Where `map_file=` finds its map: own folder first, then the map path, in order."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from fleet_common.errors import MapNotFoundError
from fleet_common.formats import mapsearch
from fleet_common.formats.mapsearch import default_map_dirs, resolve_map


def make_map(folder: Path, name: str = "m.map") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text("height 1\nwidth 1\nmap\n.\n")
    return path


def test_the_referring_files_folder_wins_over_the_map_dirs(tmp_path):
    own = make_map(tmp_path / "own")
    make_map(tmp_path / "a")
    assert resolve_map("m.map", tmp_path / "own", [tmp_path / "a"]) == own


def test_map_dirs_are_searched_in_order(tmp_path):
    make_map(tmp_path / "b")
    first = make_map(tmp_path / "a")
    dirs = [tmp_path / "missing", tmp_path / "a", tmp_path / "b"]
    assert resolve_map("m.map", tmp_path / "own", dirs) == first
    assert resolve_map("m.map", None, dirs[::-1]) == tmp_path / "b" / "m.map"


def test_a_name_with_folders_is_tried_as_written_then_by_basename(tmp_path):
    nested = make_map(tmp_path / "own" / "maps")
    flat = make_map(tmp_path / "dir")
    assert resolve_map("maps/m.map", tmp_path / "own", [tmp_path / "dir"]) == nested
    assert resolve_map("elsewhere/m.map", tmp_path / "own", [tmp_path / "dir"]) == flat


def test_an_absolute_name_that_exists_is_used(tmp_path):
    path = make_map(tmp_path / "x")
    assert resolve_map(str(path), None, []) == path


def test_not_found_lists_every_folder_looked_in(tmp_path):
    with pytest.raises(MapNotFoundError) as info:
        resolve_map("gone.map", tmp_path / "own", [tmp_path / "a", tmp_path / "b"])
    assert info.value.message == "map_file 'gone.map' not found; looked in: {}, {}, {}".format(
        tmp_path / "own", tmp_path / "a", tmp_path / "b")


def test_default_dirs_env_path_first_then_shared_maps_then_lab(monkeypatch, shared_data, tmp_path):
    monkeypatch.setenv("FLEETCONTROL_MAP_PATH", os.pathsep.join([str(tmp_path / "x"), "",
                                                                 str(tmp_path / "y")]))
    dirs = default_map_dirs()
    assert dirs[:2] == [tmp_path / "x", tmp_path / "y"]
    assert dirs[2].resolve() == (shared_data / "maps").resolve()
    assert dirs[3] == mapsearch._PACKAGE_DIR / "lab" and len(dirs) == 4
    # so every shipped instance finds its map without being told where
    assert resolve_map("arena.map", None, dirs).read_bytes() == (shared_data / "maps" / "arena.map").read_bytes()


def test_installed_package_without_a_checkout_skips_the_shared_maps(monkeypatch, tmp_path):
    monkeypatch.delenv("FLEETCONTROL_MAP_PATH", raising=False)
    installed = tmp_path / "lib" / "python3.11" / "site-packages" / "fleet_common"
    monkeypatch.setattr(mapsearch, "_PACKAGE_DIR", installed)
    assert default_map_dirs() == [installed / "lab"]
