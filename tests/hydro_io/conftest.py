from pathlib import Path

import pytest

#: sample exports of ADH, SMS and HEC-RAS models (each exercises a pitfall of its format)
FORMATS = Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="session")
def formats() -> Path:
    return FORMATS
