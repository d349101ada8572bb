"""Where the project's model files and shipped policy checkpoints live, and how a parser
finds the models."""

from __future__ import annotations

import os
from pathlib import Path

from pydrake.multibody.parsing import Parser

MODELS_DIR = Path(os.environ.get("LEGATO_DRAKE_MODELS",
                                 Path(__file__).resolve().parents[1] / "models"))
"""The ``models/`` folder (with ``package.xml``) served as ``package://legato_drake/``;
override with the ``LEGATO_DRAKE_MODELS`` environment variable."""


CHECKPOINTS_DIR = Path(os.environ.get("LEGATO_DRAKE_CHECKPOINTS",
                                      Path(__file__).resolve().parents[1] / "checkpoints"))
"""The ``checkpoints/`` folder of trained policies the README's demo and results use;
override with the ``LEGATO_DRAKE_CHECKPOINTS`` environment variable."""


def shipped_checkpoint(task: str) -> Path:
    """The shipped state LEGATO policy of ``task`` (``checkpoints/legato_state_<task>.pt``),
    which ``legato-drake demo`` runs by default (it may not exist for every task)."""
    return CHECKPOINTS_DIR / f"legato_state_{task}.pt"


def add_package(parser: Parser) -> Parser:
    """Registers ``package://legato_drake`` with ``parser`` (offline: no remote packages)."""
    package_xml = MODELS_DIR / "package.xml"
    if not package_xml.is_file():
        raise FileNotFoundError(f"model package not found: {package_xml} (set "
                                "LEGATO_DRAKE_MODELS to the project's models/ folder)")
    if not parser.package_map().Contains("legato_drake"):
        parser.package_map().AddPackageXml(str(package_xml))
    return parser
