<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE TS>
<TS version="2.1" language="ko_KR">
  <context>
    <name>WitCityModel</name>
    <message>
      <source>Cancelled: no output was written.</source>
      <translation>취소됨: 출력 파일을 쓰지 않았습니다.</translation>
    </message>
    <message>
      <source>Generate sample data</source>
      <translation>샘플 데이터 생성</translation>
    </message>
    <message>
      <source>Data</source>
      <translation>데이터</translation>
    </message>
    <message>
      <source>Generates a deterministic sample of the Korean national data around a centre point: buildings (TL_SPBD_BULD), roads (TL_SPRD_MANAGE) and legal dongs (TL_SCCO_EMD) as CP949 shapefiles without .cpg in EPSG:5179 with a few real-world defects, a DEM GeoTIFF in EPSG:5186 with -9999 cells and no NoData flag, and unreferenced orthoimage TIFs named by NGII 1:5,000 map-sheet number (sheet envelope + 50 m, one brightness per tile). Set either the radius or the number of buildings (0 = from the radius).</source>
      <translation>중심점 주변의 국가 공간정보 형식 샘플을 항상 같은 결과로(시드 기준) 생성합니다: 건물(TL_SPBD_BULD), 도로(TL_SPRD_MANAGE), 법정동(TL_SCCO_EMD)은 .cpg 없는 CP949 셰이프파일(EPSG:5179)이며 실제 데이터에 있는 몇 가지 오류를 포함합니다. DEM은 EPSG:5186 GeoTIFF로 NoData 지정 없이 -9999 셀을 가지며, 정사영상은 NGII 1:5,000 도엽번호로 이름 붙인 좌표 없는 TIF(도엽 범위 + 50 m, 타일마다 다른 밝기)입니다. 반경 또는 건물 수(0 = 반경으로 결정) 중 하나를 지정하십시오.</translation>
    </message>
    <message>
      <source>Centre of the study area</source>
      <translation>연구 지역 중심</translation>
    </message>
    <message>
      <source>Radius of the study area (m)</source>
      <translation>연구 지역 반경 (m)</translation>
    </message>
    <message>
      <source>Number of buildings (0 = from the radius)</source>
      <translation>건물 수 (0 = 반경으로 결정)</translation>
    </message>
    <message>
      <source>Random seed</source>
      <translation>난수 시드</translation>
    </message>
    <message>
      <source>Orthoimage pixel size (m)</source>
      <translation>정사영상 픽셀 크기 (m)</translation>
    </message>
    <message>
      <source>DEM cell size (m)</source>
      <translation>DEM 셀 크기 (m)</translation>
    </message>
    <message>
      <source>Generate orthoimage tiles</source>
      <translation>정사영상 타일 생성</translation>
    </message>
    <message>
      <source>Output folder</source>
      <translation>출력 폴더</translation>
    </message>
    <message>
      <source>Buildings (TL_SPBD_BULD)</source>
      <translation>건물 (TL_SPBD_BULD)</translation>
    </message>
    <message>
      <source>Roads (TL_SPRD_MANAGE)</source>
      <translation>도로 (TL_SPRD_MANAGE)</translation>
    </message>
    <message>
      <source>Legal dongs (TL_SCCO_EMD)</source>
      <translation>법정동 (TL_SCCO_EMD)</translation>
    </message>
    <message>
      <source>DEM</source>
      <translation>DEM (수치표고모델)</translation>
    </message>
    <message>
      <source>Orthoimage tile folder</source>
      <translation>정사영상 타일 폴더</translation>
    </message>
    <message>
      <source>Sample manifest (JSON)</source>
      <translation>샘플 목록 (JSON)</translation>
    </message>
    <message>
      <source>Buildings written</source>
      <translation>생성된 건물 수</translation>
    </message>
    <message>
      <source>Orthoimage tiles written</source>
      <translation>생성된 정사영상 타일 수</translation>
    </message>
    <message>
      <source>WIT City Model</source>
      <translation>WIT 도시모델</translation>
    </message>
    <message>
      <source>WIT City Model: textured CityGML 3.0 from Korean national GIS data</source>
      <translation>WIT 도시모델: 국가 공간정보로 텍스처 CityGML 3.0 생성</translation>
    </message>
  </context>
</TS>
