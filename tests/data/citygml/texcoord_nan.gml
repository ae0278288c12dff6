<?xml version="1.0" encoding="UTF-8"?>
<!-- Test fixture derived from shared/schemas/examples/handmade_LOD1_textured_building_TIN_group.gml: a roof texture coordinate is NaN (a valid xs:double, so only the texture check catches it). -->
<core:CityModel gml:id="cm_1"
  xmlns:core="http://www.opengis.net/citygml/3.0"
  xmlns:bldg="http://www.opengis.net/citygml/building/3.0"
  xmlns:con="http://www.opengis.net/citygml/construction/3.0"
  xmlns:app="http://www.opengis.net/citygml/appearance/3.0"
  xmlns:dem="http://www.opengis.net/citygml/relief/3.0"
  xmlns:gen="http://www.opengis.net/citygml/generics/3.0"
  xmlns:grp="http://www.opengis.net/citygml/cityobjectgroup/3.0"
  xmlns:gml="http://www.opengis.net/gml/3.2"
  xmlns:xlink="http://www.w3.org/1999/xlink"
  xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
  xsi:schemaLocation="http://www.opengis.net/citygml/3.0 http://schemas.opengis.net/citygml/3.0/core.xsd http://www.opengis.net/citygml/building/3.0 http://schemas.opengis.net/citygml/building/3.0/building.xsd http://www.opengis.net/citygml/appearance/3.0 http://schemas.opengis.net/citygml/appearance/3.0/appearance.xsd http://www.opengis.net/citygml/relief/3.0 http://schemas.opengis.net/citygml/relief/3.0/relief.xsd http://www.opengis.net/citygml/generics/3.0 http://schemas.opengis.net/citygml/generics/3.0/generics.xsd http://www.opengis.net/citygml/cityobjectgroup/3.0 http://schemas.opengis.net/citygml/cityobjectgroup/3.0/cityObjectGroup.xsd">
  <gml:boundedBy>
    <gml:Envelope srsName="http://www.opengis.net/def/crs-compound?1=http://www.opengis.net/def/crs/EPSG/0/25832&amp;2=http://www.opengis.net/def/crs/EPSG/0/7837" srsDimension="3">
      <gml:lowerCorner>458870.0 5438345.0 112.0</gml:lowerCorner>
      <gml:upperCorner>458890.0 5438360.0 116.0</gml:upperCorner>
    </gml:Envelope>
  </gml:boundedBy>
  <core:cityObjectMember>
    <bldg:Building gml:id="bldg_1">
      <gml:name>Building 1 (from footprint shapefile feature 1)</gml:name>
      <core:creationDate>2024-01-01T00:00:00</core:creationDate>
      <core:relativeToTerrain>entirelyAboveTerrain</core:relativeToTerrain>
      <core:genericAttribute>
        <gen:StringAttribute>
          <gen:name>source_fid</gen:name>
          <gen:value>1</gen:value>
        </gen:StringAttribute>
      </core:genericAttribute>
      <core:lod1Solid>
        <gml:Solid gml:id="bldg_1_lod1">
          <gml:exterior>
            <gml:Shell>
              <gml:surfaceMember>
                <gml:Polygon gml:id="bldg_1_ground">
                  <gml:exterior>
                    <gml:LinearRing gml:id="bldg_1_ground_r">
                      <gml:posList srsDimension="3">458875.0 5438350.0 112.0 458875.0 5438355.0 112.0 458885.0 5438355.0 112.0 458885.0 5438350.0 112.0 458875.0 5438350.0 112.0</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
              <gml:surfaceMember>
                <gml:Polygon gml:id="bldg_1_roof">
                  <gml:exterior>
                    <gml:LinearRing gml:id="bldg_1_roof_r">
                      <gml:posList srsDimension="3">458875.0 5438350.0 116.0 458885.0 5438350.0 116.0 458885.0 5438355.0 116.0 458875.0 5438355.0 116.0 458875.0 5438350.0 116.0</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
              <gml:surfaceMember>
                <gml:Polygon gml:id="bldg_1_wall_s">
                  <gml:exterior>
                    <gml:LinearRing gml:id="bldg_1_wall_s_r">
                      <gml:posList srsDimension="3">458875.0 5438350.0 112.0 458885.0 5438350.0 112.0 458885.0 5438350.0 116.0 458875.0 5438350.0 116.0 458875.0 5438350.0 112.0</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
              <gml:surfaceMember>
                <gml:Polygon gml:id="bldg_1_wall_e">
                  <gml:exterior>
                    <gml:LinearRing gml:id="bldg_1_wall_e_r">
                      <gml:posList srsDimension="3">458885.0 5438350.0 112.0 458885.0 5438355.0 112.0 458885.0 5438355.0 116.0 458885.0 5438350.0 116.0 458885.0 5438350.0 112.0</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
              <gml:surfaceMember>
                <gml:Polygon gml:id="bldg_1_wall_n">
                  <gml:exterior>
                    <gml:LinearRing gml:id="bldg_1_wall_n_r">
                      <gml:posList srsDimension="3">458885.0 5438355.0 112.0 458875.0 5438355.0 112.0 458875.0 5438355.0 116.0 458885.0 5438355.0 116.0 458885.0 5438355.0 112.0</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
              <gml:surfaceMember>
                <gml:Polygon gml:id="bldg_1_wall_w">
                  <gml:exterior>
                    <gml:LinearRing gml:id="bldg_1_wall_w_r">
                      <gml:posList srsDimension="3">458875.0 5438355.0 112.0 458875.0 5438350.0 112.0 458875.0 5438350.0 116.0 458875.0 5438355.0 116.0 458875.0 5438355.0 112.0</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:Shell>
          </gml:exterior>
        </gml:Solid>
      </core:lod1Solid>
      <con:height>
        <con:Height>
          <con:highReference>highestRoofEdge</con:highReference>
          <con:lowReference>lowestGroundPoint</con:lowReference>
          <con:status>measured</con:status>
          <con:value uom="m">4.0</con:value>
        </con:Height>
      </con:height>
      <bldg:storeysAboveGround>1</bldg:storeysAboveGround>
    </bldg:Building>
  </core:cityObjectMember>
  <core:cityObjectMember>
    <dem:ReliefFeature gml:id="relief_1">
      <dem:lod>1</dem:lod>
      <dem:reliefComponent>
        <dem:TINRelief gml:id="tin_1">
          <dem:lod>1</dem:lod>
          <dem:tin>
            <gml:TriangulatedSurface gml:id="tin_1_surface">
              <gml:patches>
                <gml:Triangle>
                  <gml:exterior>
                    <gml:LinearRing gml:id="tin_1_t0">
                      <gml:posList srsDimension="3">458870.0 5438345.0 112.0 458890.0 5438345.0 112.0 458890.0 5438360.0 112.5 458870.0 5438345.0 112.0</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Triangle>
                <gml:Triangle>
                  <gml:exterior>
                    <gml:LinearRing gml:id="tin_1_t1">
                      <gml:posList srsDimension="3">458870.0 5438345.0 112.0 458890.0 5438360.0 112.5 458870.0 5438360.0 112.5 458870.0 5438345.0 112.0</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Triangle>
              </gml:patches>
            </gml:TriangulatedSurface>
          </dem:tin>
        </dem:TINRelief>
      </dem:reliefComponent>
    </dem:ReliefFeature>
  </core:cityObjectMember>
  <core:cityObjectMember>
    <grp:CityObjectGroup gml:id="grp_1">
      <gml:name>Buildings of tile 1</gml:name>
      <grp:groupMember>
        <grp:Role>
          <grp:role>member</grp:role>
          <grp:groupMember xlink:href="#bldg_1"/>
        </grp:Role>
      </grp:groupMember>
    </grp:CityObjectGroup>
  </core:cityObjectMember>
  <core:appearanceMember>
    <app:Appearance gml:id="app_ortho">
      <app:theme>orthophoto</app:theme>
      <app:surfaceData>
        <app:ParameterizedTexture gml:id="tex_tile_1">
          <app:imageURI>textures/tile_1.jpg</app:imageURI>
          <app:mimeType>image/jpeg</app:mimeType>
          <app:wrapMode>none</app:wrapMode>
          <app:textureParameterization>
            <app:TextureAssociation>
              <app:target>#bldg_1_roof</app:target>
              <app:textureParameterization>
                <app:TexCoordList>
                  <app:textureCoordinates>0.25 0.3333333 NaN 0.3333333 0.75 0.6666667 0.25 0.6666667 0.25 0.3333333</app:textureCoordinates>
                  <app:ring>#bldg_1_roof_r</app:ring>
                </app:TexCoordList>
              </app:textureParameterization>
            </app:TextureAssociation>
          </app:textureParameterization>
          <app:textureParameterization>
            <app:TextureAssociation>
              <app:target>#tin_1_surface</app:target>
              <app:textureParameterization>
                <app:TexCoordList>
                  <app:textureCoordinates>0.0 0.0 1.0 0.0 1.0 1.0 0.0 0.0</app:textureCoordinates>
                  <app:textureCoordinates>0.0 0.0 1.0 1.0 0.0 1.0 0.0 0.0</app:textureCoordinates>
                  <app:ring>#tin_1_t0</app:ring>
                  <app:ring>#tin_1_t1</app:ring>
                </app:TexCoordList>
              </app:textureParameterization>
            </app:TextureAssociation>
          </app:textureParameterization>
        </app:ParameterizedTexture>
      </app:surfaceData>
    </app:Appearance>
  </core:appearanceMember>
</core:CityModel>
