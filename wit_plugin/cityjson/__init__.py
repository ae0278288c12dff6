"""CityJSON 2.0 and CityJSONSeq: the model of the CityGML writer in the JSON encoding the 3D city tools read.

``objects`` reads the chain's step layers into city objects (the same ids, attributes, semantics and
texture coordinates as ``citygml.writer``); ``encoding`` turns their geometry into CityJSON's integer
vertices and index arrays; ``writer`` writes one CityJSON file, or a CityJSONSeq (a header line, then
one feature a line) that a tile of a run shares with its neighbours; ``validate`` checks either
against the official schemas (``schemas/``) and with the CityGML validator's geometric checks.
"""
