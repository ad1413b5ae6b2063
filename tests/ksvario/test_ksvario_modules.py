"""Modules and configuration rules (KS VARIO interface description 3.1, 3.5): one test per rule,
Chk_Cfg bytes."""

from __future__ import annotations

import pytest

from pyuss.errors import ConfigError
from pyuss.ksvario.modules import (
    MODULES,
    Configuration,
    decode_chk_cfg,
    ident_sizes,
    module,
    parse_modules,
)
from support.paths import load_vectors

VECTORS = load_vectors("ksvario")

SIZES = {
    "A.1": (8, 8),
    "A.2": (4, 4),
    "A.3": (6, 6),
    "A.4": (12, 12),
    "A.5": (20, 20),
    "A.6": (32, 32),
    "A.7": (0, 1),
    "B.1": (2, 0),
    "B.2": (4, 0),
    "B.3": (8, 0),
    "B.4": (16, 0),
    "B.5": (32, 0),
    "B.6": (0, 2),
    "B.7": (0, 4),
    "B.8": (0, 8),
    "B.9": (0, 16),
    "B.10": (0, 32),
}


def test_identifier_bytes_of_the_vectors() -> None:
    ids = {k: int(v, 16) for k, v in VECTORS["module_ids"].items()}
    assert {m.key: m.ident for m in MODULES} == ids
    assert len(MODULES) == 17


@pytest.mark.parametrize("m", MODULES, ids=lambda m: m.key)
def test_module_sizes_match_the_document_table(m) -> None:  # type: ignore[no-untyped-def]
    assert (m.inputs, m.outputs) == SIZES[m.key]
    assert ident_sizes(m.ident) == SIZES[m.key]


def test_chk_cfg_bytes_and_back() -> None:
    conf = Configuration(parse_modules("A.1,B.5,B.1,B.10,B.6"))
    assert conf.chk_cfg() == bytes.fromhex("F3 5F 50 6F 60")
    assert decode_chk_cfg(conf.chk_cfg()) == list(conf.modules)
    assert conf.input_bytes == 8 + 32 + 2 and conf.output_bytes == 8 + 32 + 2
    assert [s.in_offset for s in conf.slots] == [0, 8, 40, 42, 42]


def test_unknown_chk_cfg_byte_is_named() -> None:
    with pytest.raises(ConfigError, match=r"byte 1 \(13h\)"):
        decode_chk_cfg(bytes((0xF3, 0x13)))


def test_module_names() -> None:
    assert module("a1").key == "A.1" and module("B10").key == "B.10"
    with pytest.raises(ConfigError, match="unknown module"):
        module("C.1")


def test_rule_at_least_one_module() -> None:
    with pytest.raises(ConfigError, match="at least one module"):
        Configuration([])


def test_rule_parameter_channel_once() -> None:
    with pytest.raises(ConfigError, match=r"A\.1 may be configured only once"):
        Configuration(["A.1", "A.1"])


def test_rule_variable_multiplexer_once() -> None:
    with pytest.raises(ConfigError, match=r"A\.2 may be configured only once"):
        Configuration(["A.2", "B.1", "A.2", "B.1"])


def test_rule_parameter_channel_not_after_variable_multiplexer() -> None:
    with pytest.raises(ConfigError, match="cannot come after"):
        Configuration(["A.2", "B.1", "A.1"])
    Configuration(["A.1", "A.2", "B.1"])


def test_rule_io_module_after_variable_multiplexer() -> None:
    with pytest.raises(ConfigError, match="at least one I/O module"):
        Configuration(["B.1", "A.2"])
    with pytest.raises(ConfigError, match="at least one I/O module"):
        Configuration(["A.2", "A.7"])


def test_rule_at_most_50_modules() -> None:
    Configuration(["B.1"] * 50)
    with pytest.raises(ConfigError, match="51 modules"):
        Configuration(["B.1"] * 51)


def test_rule_244_bytes_each_way() -> None:
    Configuration(["B.5"] * 7 + ["B.3"] + ["B.10"] * 7 + ["B.8"])  # 232 + 8 = 240 each way
    with pytest.raises(ConfigError, match="246 input bytes"):
        Configuration(["B.5"] * 7 + ["B.4"] + ["B.1"] * 3)
    with pytest.raises(ConfigError, match="output bytes"):
        Configuration(["B.10"] * 8)


def test_rule_single_data_and_parameter_channel_before_fixed_multiplexer() -> None:
    Configuration(["A.1", "B.1", "A.4", "A.6"])
    with pytest.raises(ConfigError, match="before the first fixed multiplexer"):
        Configuration(["A.4", "B.1"])
    with pytest.raises(ConfigError, match="before the first fixed multiplexer"):
        Configuration(["A.3", "A.1"])
