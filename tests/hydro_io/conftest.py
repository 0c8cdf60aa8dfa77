from pathlib import Path

import pytest

#: copies of the samples in shared/formats (the grammar notes there list every pitfall they exercise)
FORMATS = Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="session")
def formats() -> Path:
    return FORMATS
