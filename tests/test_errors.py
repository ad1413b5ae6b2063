"""The exception tree: one root, and a drive's refusal carries its number and meaning."""

import pytest

from pyuss.errors import ConfigError, DriveRefusal, TelegramError, UssError


def test_refusal_carries_number_and_meaning() -> None:
    err = DriveRefusal(0, "illegal parameter number", pnu=999)
    assert err.number == 0
    assert err.meaning == "illegal parameter number"
    assert "PNU 999" in str(err)
    assert isinstance(err, UssError)


@pytest.mark.parametrize("cls", [ConfigError, TelegramError])
def test_value_errors_are_uss_errors(cls: type[Exception]) -> None:
    assert issubclass(cls, UssError)
    assert issubclass(cls, ValueError)
