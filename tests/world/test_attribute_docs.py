"""Field meanings are the attribute docstrings, read from the source when documented (not at import)."""

from agvnav.world.strict import StrictModel, attribute_docs
from agvnav.world.vehicle_specs import TricycleSpec


class _Base(StrictModel):
    """A base section."""

    x_m: float = 1.0
    """the x offset."""
    y: int = 0
    """y of the base."""
    untold: int = 0


class _Derived(_Base):
    y: int = 2
    """y as the derived class
    says it."""
    z: str = ""
    w: int = 0  # a comment is no docstring


def test_attribute_docs_follow_the_class_that_declares_the_field():
    assert attribute_docs(_Base) == {"x_m": "the x offset.", "y": "y of the base."}
    assert attribute_docs(_Derived) == {"x_m": "the x offset.", "y": "y as the derived class\nsays it."}


def test_models_carry_no_description_at_import_but_the_reference_reads_them():
    assert all(f.description is None for f in TricycleSpec.model_fields.values())
    docs = attribute_docs(TricycleSpec)
    assert docs and all(docs.values())
