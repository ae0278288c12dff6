"""The XML namespaces of CityGML 3.0 and of the standards it builds on: one table for the writer,
the reader, the validator and the metrics, with the conventional prefix of each."""
from __future__ import annotations

URIS = {  # conventional prefix → namespace
    "core": "http://www.opengis.net/citygml/3.0",
    "bldg": "http://www.opengis.net/citygml/building/3.0",
    "con": "http://www.opengis.net/citygml/construction/3.0",
    "tran": "http://www.opengis.net/citygml/transportation/3.0",
    "dem": "http://www.opengis.net/citygml/relief/3.0",
    "app": "http://www.opengis.net/citygml/appearance/3.0",
    "gen": "http://www.opengis.net/citygml/generics/3.0",
    "grp": "http://www.opengis.net/citygml/cityobjectgroup/3.0",
    "brid": "http://www.opengis.net/citygml/bridge/3.0",
    "tun": "http://www.opengis.net/citygml/tunnel/3.0",
    "frn": "http://www.opengis.net/citygml/cityfurniture/3.0",
    "luse": "http://www.opengis.net/citygml/landuse/3.0",
    "veg": "http://www.opengis.net/citygml/vegetation/3.0",
    "wtr": "http://www.opengis.net/citygml/waterbody/3.0",
    "dyn": "http://www.opengis.net/citygml/dynamizer/3.0",
    "pcl": "http://www.opengis.net/citygml/pointcloud/3.0",
    "vers": "http://www.opengis.net/citygml/versioning/3.0",
    "gml": "http://www.opengis.net/gml/3.2",
    "xlink": "http://www.w3.org/1999/xlink",
    "xsi": "http://www.w3.org/2001/XMLSchema-instance",
    "xAL": "urn:oasis:names:tc:ciq:xal:3",
    "xs": "http://www.w3.org/2001/XMLSchema",
}
PREFIXES = {uri: prefix for prefix, uri in URIS.items()}  # namespace → prefix, for messages that read like XML
CITYGML3_NAMESPACES = frozenset(uri for uri in URIS.values() if uri.startswith("http://www.opengis.net/citygml/"))

CORE, BLDG, CON, TRAN, DEM, APP, GEN, GRP, GML, XLINK, XSI = (
    f"{{{URIS[prefix]}}}" for prefix in ("core", "bldg", "con", "tran", "dem", "app", "gen", "grp", "gml", "xlink",
                                         "xsi"))
"""``{namespace}``: put before a local name to make the element or attribute name lxml uses."""
GML_ID = GML + "id"
HREF = XLINK + "href"
