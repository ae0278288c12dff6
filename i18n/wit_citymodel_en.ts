<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE TS>
<TS version="2.1" language="en_US">
  <context>
    <name>WitCityModel</name>
    <message>
      <source>Cancelled: no output was written.</source>
      <translation>Cancelled: no output was written.</translation>
    </message>
    <message>
      <source>Generate sample data</source>
      <translation>Generate sample data</translation>
    </message>
    <message>
      <source>Data</source>
      <translation>Data</translation>
    </message>
    <message>
      <source>Generates a deterministic sample of the Korean national data around a centre point: buildings (TL_SPBD_BULD), roads (TL_SPRD_MANAGE) and legal dongs (TL_SCCO_EMD) as CP949 shapefiles without .cpg in EPSG:5179 with a few real-world defects, a DEM GeoTIFF in EPSG:5186 with -9999 cells and no NoData flag, and unreferenced orthoimage TIFs named by NGII 1:5,000 map-sheet number (sheet envelope + 50 m, one brightness per tile). Set either the radius or the number of buildings (0 = from the radius).</source>
      <translation>Generates a deterministic sample of the Korean national data around a centre point: buildings (TL_SPBD_BULD), roads (TL_SPRD_MANAGE) and legal dongs (TL_SCCO_EMD) as CP949 shapefiles without .cpg in EPSG:5179 with a few real-world defects, a DEM GeoTIFF in EPSG:5186 with -9999 cells and no NoData flag, and unreferenced orthoimage TIFs named by NGII 1:5,000 map-sheet number (sheet envelope + 50 m, one brightness per tile). Set either the radius or the number of buildings (0 = from the radius).</translation>
    </message>
    <message>
      <source>Centre of the study area</source>
      <translation>Centre of the study area</translation>
    </message>
    <message>
      <source>Radius of the study area (m)</source>
      <translation>Radius of the study area (m)</translation>
    </message>
    <message>
      <source>Number of buildings (0 = from the radius)</source>
      <translation>Number of buildings (0 = from the radius)</translation>
    </message>
    <message>
      <source>Random seed</source>
      <translation>Random seed</translation>
    </message>
    <message>
      <source>Orthoimage pixel size (m)</source>
      <translation>Orthoimage pixel size (m)</translation>
    </message>
    <message>
      <source>DEM cell size (m)</source>
      <translation>DEM cell size (m)</translation>
    </message>
    <message>
      <source>Generate orthoimage tiles</source>
      <translation>Generate orthoimage tiles</translation>
    </message>
    <message>
      <source>Output folder</source>
      <translation>Output folder</translation>
    </message>
    <message>
      <source>Buildings (TL_SPBD_BULD)</source>
      <translation>Buildings (TL_SPBD_BULD)</translation>
    </message>
    <message>
      <source>Roads (TL_SPRD_MANAGE)</source>
      <translation>Roads (TL_SPRD_MANAGE)</translation>
    </message>
    <message>
      <source>Legal dongs (TL_SCCO_EMD)</source>
      <translation>Legal dongs (TL_SCCO_EMD)</translation>
    </message>
    <message>
      <source>DEM</source>
      <translation>DEM</translation>
    </message>
    <message>
      <source>Orthoimage tile folder</source>
      <translation>Orthoimage tile folder</translation>
    </message>
    <message>
      <source>Sample manifest (JSON)</source>
      <translation>Sample manifest (JSON)</translation>
    </message>
    <message>
      <source>Buildings written</source>
      <translation>Buildings written</translation>
    </message>
    <message>
      <source>Orthoimage tiles written</source>
      <translation>Orthoimage tiles written</translation>
    </message>
    <message>
      <source>WIT City Model</source>
      <translation>WIT City Model</translation>
    </message>
    <message>
      <source>WIT City Model: textured CityGML 3.0 from Korean national GIS data</source>
      <translation>WIT City Model: textured CityGML 3.0 from Korean national GIS data</translation>
    </message>
  </context>
</TS>
