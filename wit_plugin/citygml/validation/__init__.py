"""The parts of ``citygml.validate``: streaming parse, XSD, the other checks, geometry, CRS units."""
