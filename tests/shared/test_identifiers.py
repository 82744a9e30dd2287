"""GUID ↔ bus key and GUID ↔ folder mappings: reversible, safe for Zenoh and for every file system."""

from __future__ import annotations

import random
import uuid

import ifcopenshell.guid
import pytest
import zenoh

from bimbot.shared.identifiers import (
    folder_to_guid,
    guid_to_folder,
    guid_to_key,
    is_valid_guid,
    key_to_guid,
    slugify,
)

GUIDS_WITH_DOLLAR_AND_UNDERSCORE = [
    "0rBru4syGxGOZb$M8kVJuS",
    "2Y5tFvjSfCngQp$$PYkXhS",
    "2hWL_Juob0BPVRlnbe1v3c",
    "3_$_$_$_$_$_$_$_$_$_$_",
]


# fifty more from a seeded generator: the same on every run and in every pytest worker
_RNG = random.Random(20261126)
RANDOM_GUIDS = [ifcopenshell.guid.compress(uuid.UUID(int=_RNG.getrandbits(128)).hex) for _ in range(50)]


@pytest.mark.parametrize("guid", GUIDS_WITH_DOLLAR_AND_UNDERSCORE + RANDOM_GUIDS)
def test_guid_key_round_trip_and_zenoh_accepts_the_key(guid: str) -> None:
    key = guid_to_key(guid)
    assert "$" not in key
    assert key_to_guid(key) == guid
    zenoh.KeyExpr(f"bimbot/site/components/{key}/state")  # raises on a forbidden character


def test_dollar_maps_to_hyphen_and_underscore_stays() -> None:
    assert guid_to_key("1ZYEEONkr85w1TbdaOn$Js") == "1ZYEEONkr85w1TbdaOn-Js"
    assert guid_to_key("2hWL_Juob0BPVRlnbe1v3c") == "2hWL_Juob0BPVRlnbe1v3c"


@pytest.mark.parametrize("odd", ["a/b*c#d?", "Träger 1", "x.y-z", "$"])
def test_non_conforming_ids_still_map_reversibly_to_valid_keys(odd: str) -> None:
    key = guid_to_key(odd)
    assert key_to_guid(key) == odd
    zenoh.KeyExpr(f"bimbot/s/components/{key}")


def test_key_with_a_character_no_guid_maps_to_is_rejected() -> None:
    with pytest.raises(ValueError, match="no GlobalId maps to"):
        key_to_guid("abc*")


@pytest.mark.parametrize("guid", [*GUIDS_WITH_DOLLAR_AND_UNDERSCORE, "not a guid/../x"])
def test_folder_round_trip_is_uri_and_os_safe(guid: str) -> None:
    folder = guid_to_folder(guid)
    assert folder_to_guid(folder) == guid
    assert all(char in "0123456789abcdefx" for char in folder)


def test_guids_differing_only_in_case_get_folders_distinct_on_case_insensitive_file_systems() -> None:
    lower, upper = "2hwl_juob0bpvrlnbe1v3c", "2HWL_JUOB0BPVRLNBE1V3C"
    assert is_valid_guid(lower) and is_valid_guid(upper)
    assert guid_to_folder(lower).lower() != guid_to_folder(upper).lower()


def test_slugify_keeps_paths_and_keys_safe() -> None:
    assert slugify("Greenhouse Site") == "greenhouse-site"
    assert slugify('Bau/"Süd" 1') == "bau-sud-1"
    assert slugify("") == "site"
    assert slugify("///") == "site"
