"""Where the project's model files live and how a parser finds them."""

from __future__ import annotations

import os
from pathlib import Path

from pydrake.multibody.parsing import Parser

MODELS_DIR = Path(os.environ.get("LEGATO_DRAKE_MODELS",
                                 Path(__file__).resolve().parents[1] / "models"))
"""The ``models/`` folder (with ``package.xml``) served as ``package://legato_drake/``;
override with the ``LEGATO_DRAKE_MODELS`` environment variable."""


def add_package(parser: Parser) -> Parser:
    """Registers ``package://legato_drake`` with ``parser`` (offline: no remote packages)."""
    package_xml = MODELS_DIR / "package.xml"
    if not package_xml.is_file():
        raise FileNotFoundError(f"model package not found: {package_xml} (set "
                                "LEGATO_DRAKE_MODELS to the project's models/ folder)")
    if not parser.package_map().Contains("legato_drake"):
        parser.package_map().AddPackageXml(str(package_xml))
    return parser
