<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE TS>
<TS version="2.1" language="ko_KR">
  <context>
    <name>WitCityModel</name>
    <message>
      <source>WIT City Model</source>
      <translation>WIT 도시모델</translation>
    </message>
    <message>
      <source>Install Python dependencies…</source>
      <translation>파이썬 의존 패키지 설치…</translation>
    </message>
    <message>
      <source>Missing Python packages: {packages}.</source>
      <translation>없는 파이썬 패키지: {packages}.</translation>
    </message>
    <message>
      <source>Build a spatial index (slower to write, faster to display)</source>
      <translation>공간 인덱스 생성 (쓰기는 느려지고 표시는 빨라짐)</translation>
    </message>
    <message>
      <source>Cancelled: no output was written.</source>
      <translation>취소됨: 출력 파일을 쓰지 않았습니다.</translation>
    </message>
    <message>
      <source>Missing Python packages: {packages}. Run 'Install Python dependencies' (wit:installdependencies, group Tools) to install them into your QGIS profile.</source>
      <translation>없는 파이썬 패키지: {packages}. '파이썬 의존 패키지 설치'(wit:installdependencies, 도구 그룹)를 실행하면 QGIS 프로필에 설치됩니다.</translation>
    </message>
    <message>
      <source>Run 'Install Python dependencies' (wit:installdependencies, group Tools) to install a shapely that uses QGIS's GEOS into your QGIS profile, then restart QGIS.</source>
      <translation>'파이썬 의존 패키지 설치'(wit:installdependencies, 도구 그룹)를 실행하여 QGIS의 GEOS를 쓰는 shapely를 QGIS 프로필에 설치한 뒤 QGIS를 다시 시작하십시오.</translation>
    </message>
    <message>
      <source>City model (whole chain)</source>
      <translation>도시모델 (전체 처리)</translation>
    </message>
    <message>
      <source>Chain</source>
      <translation>전체 처리</translation>
    </message>
    <message>
      <source>Runs the whole chain in one call, with one progress bar and Cancel honoured in every step: prepare the building, road and legal-dong layers for the study area; check, in seconds and before any heavy work, that the DEM and the orthoimage sheets (from their sheet numbers) cover it, naming the missing sheets (a DEM, or sheets georeferenced in another CRS than the target, are reprojected on the fly, bilinear); georeference and merge only the sheets it needs (WIT feather + gain); triangulate the terrain (it also covers the buildings that cross the area's edge); extrude LoD1 buildings (heights as in wit:extrudebuildings: floors, a height field or expression, or the height and floor fields of the common layers recognised by name; buildings given the default height are a warning and the DEFAULT_HEIGHTS output); texture them from the orthoimage (walls: generated facades from each building's use and storeys, marked as generated; FACADES); write CityGML 3.0, validate it and measure its quality. The output folder receives model.gml with its textures (and, with CITYJSON, the same model as CityJSON 2.0: model.city.json, validated alike), validation.html, metrics.csv (and metrics.html), the LoD1 and TIN GeoPackages, a 3D Tiles 1.1 tileset (3dtiles/, for CesiumJS or QGIS ≥ 3.34) and steps.json (time per step); from the QGIS window the layers load into the project as a group for the 3D map view. Everything appears at the end, so a failed or cancelled run leaves nothing. Intermediate files are deleted unless kept (then in &lt;output&gt;/work). Study area: a legal dong (code or name) if given, else the polygon layer, else the centre point and radius. Run again into the same folder, it compares what the model was built from (build.json: every setting, the plugin's version, the triangulator, and the inputs as the run reads them, by content) and builds it again only if something changed, saying what (REBUILT, REBUILD_REASON); otherwise it does no work and reports the result recorded. REBUILD builds it again anyway.</source>
      <translation>데이터에서 검증된 CityGML 3.0까지 전체 과정을 한 번에 실행합니다. 진행 막대는 하나이고 모든 단계에서 취소가 동작합니다: 연구 지역의 건물·도로·법정동 레이어를 준비하고, 무거운 작업 전에 DEM과 정사영상 도엽(도엽 번호로 판단)이 지역을 덮는지 몇 초 안에 확인해 빠진 도엽 번호를 알려 주며(대상 좌표계와 다른 좌표계의 DEM이나 다른 좌표계로 지리참조된 도엽은 실행 중에 바로 재투영합니다, 쌍선형), 필요한 도엽만 지리참조하고 병합합니다(WIT 페더링 + 게인). 지형을 삼각망으로 만들고(지역 경계를 넘는 건물까지 덮음), LoD1 건물을 돌출합니다(높이는 wit:extrudebuildings와 같음: 층수, 높이 필드나 식, 또는 흔한 레이어의 높이·층수 필드를 이름으로 인식; 기본 높이를 받은 건물은 경고와 DEFAULT_HEIGHTS 출력으로 알림). 정사영상으로 텍스처를 입히고(벽: 각 건물의 용도와 층수로 생성한 외벽 텍스처, 생성된 것임을 표시; FACADES) CityGML 3.0을 쓰고 검증하며 품질을 측정합니다. 출력 폴더에는 텍스처와 함께 model.gml(CITYJSON을 켜면 같은 모델을 CityJSON 2.0으로 쓴 model.city.json도, 함께 검증됨), validation.html, metrics.csv(및 metrics.html), LoD1과 TIN GeoPackage, 3D Tiles 1.1 타일셋(3dtiles/, CesiumJS나 QGIS 3.34 이상용), steps.json(단계별 시간)이 생깁니다. QGIS 창에서 실행하면 레이어가 그룹으로 프로젝트에 올라와 3D 지도 보기에 바로 나타납니다. 모든 결과는 마지막에 한꺼번에 나타나므로 실패하거나 취소된 실행은 아무것도 남기지 않습니다. 중간 파일은 보관하지 않으면 지워집니다(보관하면 &lt;output&gt;/work). 연구 지역: 법정동(코드 또는 이름)을 주면 그것, 아니면 폴리곤 레이어, 아니면 중심점과 반경. 같은 폴더에 다시 실행하면 모델이 무엇으로 만들어졌는지(build.json: 모든 설정, 플러그인 버전, 삼각분할 라이브러리, 그리고 실행이 읽는 입력을 내용으로) 비교해 무언가 바뀌었을 때만 다시 만들고 무엇이 바뀌었는지 알려 줍니다(REBUILT, REBUILD_REASON). 바뀐 것이 없으면 아무 작업도 하지 않고 기록된 결과를 알려 줍니다. REBUILD를 켜면 그래도 다시 만듭니다.</translation>
    </message>
    <message>
      <source>Write a 3D Tiles 1.1 tileset for viewers (3dtiles/)</source>
      <translation>뷰어용 3D Tiles 1.1 타일셋 쓰기 (3dtiles/)</translation>
    </message>
    <message>
      <source>Keep the intermediate files</source>
      <translation>중간 파일 유지</translation>
    </message>
    <message>
      <source>Output folder</source>
      <translation>출력 폴더</translation>
    </message>
    <message>
      <source>CityGML file</source>
      <translation>CityGML 파일</translation>
    </message>
    <message>
      <source>CityJSON file (model.city.json)</source>
      <translation>CityJSON 파일 (model.city.json)</translation>
    </message>
    <message>
      <source>Validation report (HTML)</source>
      <translation>검증 보고서 (HTML)</translation>
    </message>
    <message>
      <source>Metrics table (CSV)</source>
      <translation>지표 표 (CSV)</translation>
    </message>
    <message>
      <source>All files valid</source>
      <translation>모든 파일 유효</translation>
    </message>
    <message>
      <source>Number of errors</source>
      <translation>오류 수</translation>
    </message>
    <message>
      <source>Buildings written</source>
      <translation>생성된 건물 수</translation>
    </message>
    <message>
      <source>Buildings with the default height</source>
      <translation>기본 높이를 쓴 건물 수</translation>
    </message>
    <message>
      <source>Surfaces left untextured outside the orthoimage</source>
      <translation>정사영상 밖이라 텍스처 없이 남긴 면</translation>
    </message>
    <message>
      <source>3D Tiles tileset (tileset.json)</source>
      <translation>3D Tiles 타일셋 (tileset.json)</translation>
    </message>
    <message>
      <source>Seconds per step (JSON)</source>
      <translation>단계별 시간(초, JSON)</translation>
    </message>
    <message>
      <source>Built by this run (false: nothing had changed since the last run into the folder)</source>
      <translation>이번 실행에서 만들어짐 (false: 이 폴더에 대한 지난 실행 이후 바뀐 것이 없음)</translation>
    </message>
    <message>
      <source>Why it was built (what changed)</source>
      <translation>다시 만든 이유 (바뀐 것)</translation>
    </message>
    <message>
      <source>Orthoimage TIFs or folders</source>
      <translation>정사영상 TIF 또는 폴더</translation>
    </message>
    <message>
      <source>DEM</source>
      <translation>DEM (수치표고모델)</translation>
    </message>
    <message>
      <source>Buildings (TL_SPBD_BULD, NGII, AL_D010, OpenStreetMap…)</source>
      <translation>건물 (TL_SPBD_BULD, 국토지리정보원, AL_D010, 오픈스트리트맵…)</translation>
    </message>
    <message>
      <source>Legal dongs (TL_SCCO_EMD)</source>
      <translation>법정동 (TL_SCCO_EMD)</translation>
    </message>
    <message>
      <source>Target CRS</source>
      <translation>대상 좌표계</translation>
    </message>
    <message>
      <source>Texture scale S (0 &lt; S ≤ 1)</source>
      <translation>텍스처 배율 S (0 &lt; S ≤ 1)</translation>
    </message>
    <message>
      <source>Surfaces outside the orthoimage</source>
      <translation>정사영상 밖의 면</translation>
    </message>
    <message>
      <source>Schema folder overriding the shipped schemas (with citygml3-all.xsd)</source>
      <translation>포함된 스키마 대신 쓸 스키마 폴더 (citygml3-all.xsd 포함)</translation>
    </message>
    <message>
      <source>Fail and name the missing sheets</source>
      <translation>실패하고 빠진 도엽을 알림</translation>
    </message>
    <message>
      <source>Leave them untextured (warning)</source>
      <translation>텍스처 없이 남김 (경고)</translation>
    </message>
    <message>
      <source>City model in map-sheet tiles (Dask)</source>
      <translation>도엽 타일 단위 도시 모델 (Dask)</translation>
    </message>
    <message>
      <source>The whole chain (as wit:citymodel, with the same inputs and options) over a district or a whole city, cut into tiles on the NGII map-sheet grid (1:5,000 by default, 1:1,000 for dense cities): the sheet number is the tile id, so tiles line up with the orthoimage sheets. Area: a legal dong (code or name), else a polygon layer, else a bounding box, else everything the buildings layer covers (when asked), else the centre and radius. Every building belongs to exactly one tile, the sheet of its point on surface; the terrain of neighbouring tiles shares its border vertices and heights, roads are cut along the same border, and a building crossing it lies on terrain in its own tile. Tiles run in parallel on Dask distributed: an embedded scheduler with WORKERS worker processes of a plain Python (never QGIS itself; WORKER_PYTHON to choose it), or an existing scheduler (SCHEDULER, e.g. tcp://10.0.0.5:8786: a stock dask scheduler, whose workers import the plugin's core wit_plugin and see the same files). The output folder receives tiles/&lt;sheet&gt;/model.gml (with textures and validation.html) per tile and index.gpkg, a map of the run (status done / failed / empty, buildings, triangles, seconds, peak memory, error, fingerprint, reason). A tile whose data cannot be made fails with its reason and the others go on; the algorithm then ends with an error giving the count and the first reasons, the tiles done kept; Cancel stops every tile. Run again into the same folder, it updates the city: each tile records what it was built from (every setting, the plugin's version, the triangulator, and its inputs as they fall in its area with the margin it reads, by content); the tiles whose inputs and settings have not changed are kept as they are, the others built again, tiles that left the area removed and new ones built, and the levels above refreshed where a child changed (TILES_KEPT, TILES_REBUILT with REBUILD_REASONS, TILES_ADDED, TILES_REMOVED). REBUILD builds every tile again. A tile that keeps no building (a park, a hill, buildings that all belong to neighbouring tiles or are too small) still gets its terrain and roads (status empty). With 3D Tiles on, each tile writes its tileset and tileset.json at the top of the output folder joins them into one, below groups by map sheet (1:5,000, 1:50,000, 1° block, as many levels as the run needs) that show the terrain and the largest buildings from afar (open it in the viewer, or as a 3D Tiles layer in QGIS 3.34 and later). With CITYJSON, each tile also writes model.city.jsonl, a CityJSONSeq in the run's one transform, and index.city.jsonl at the top is the run's header line listing them: its line and the tiles' features, joined, are one CityJSONSeq of the whole run.</source>
      <translation>wit:citymodel과 같은 입력과 옵션으로 전체 과정을 구나 도시 전체에 대해 실행하되, 국토지리정보원 도엽 격자(기본 1:5,000, 밀집 도시는 1:1,000)로 타일을 나눕니다. 도엽 번호가 타일 id이므로 타일이 정사영상 도엽과 맞아떨어집니다. 지역: 법정동(코드 또는 이름), 아니면 폴리곤 레이어, 아니면 범위 상자, 아니면 (요청하면) 건물 레이어 전체, 아니면 중심점과 반경. 모든 건물은 정확히 한 타일, 곧 건물 내부 대표점이 속한 도엽에 속합니다. 이웃 타일의 지형은 경계 정점과 높이를 공유하고, 도로는 같은 경계선에서 잘리며, 경계를 넘는 건물은 자기 타일의 지형 위에 놓입니다. 타일은 Dask distributed에서 병렬로 실행됩니다: 이 컴퓨터의 내장 스케줄러와 WORKERS개의 일반 Python 작업 프로세스(QGIS 자체는 절대 아님; WORKER_PYTHON으로 선택), 또는 기존 스케줄러(SCHEDULER, 예: tcp://10.0.0.5:8786: 기본 dask 스케줄러; 그 작업자는 플러그인의 코어 wit_plugin을 불러올 수 있고 같은 파일을 볼 수 있어야 함). 출력 폴더에는 타일마다 tiles/&lt;도엽&gt;/model.gml(텍스처와 validation.html 포함)과 실행 지도인 index.gpkg(상태 done / failed / empty, 건물 수, 삼각형 수, 초, 최대 메모리, 오류, 지문(fingerprint), 이유)가 생깁니다. 데이터를 만들 수 없는 타일은 그 이유와 함께 실패로 기록되고 나머지는 계속됩니다. 그러면 알고리즘은 실패 수와 첫 이유들을 담은 오류로 끝나며, 끝난 타일은 남습니다. 취소하면 모든 타일이 멈춥니다. 같은 폴더에 다시 실행하면 도시를 갱신합니다: 각 타일은 무엇으로 만들어졌는지(모든 설정, 플러그인 버전, 삼각분할 라이브러리, 그리고 타일이 읽는 여백까지 포함한 자기 영역의 입력을 내용으로) 기록하며, 입력과 설정이 바뀌지 않은 타일은 그대로 두고 나머지는 다시 만들며, 지역을 벗어난 타일은 지우고 새 타일은 만들고, 위 단계는 자식이 바뀐 곳만 새로 씁니다(TILES_KEPT, TILES_REBUILT와 REBUILD_REASONS, TILES_ADDED, TILES_REMOVED). REBUILD를 켜면 모든 타일을 다시 만듭니다. 남는 건물이 하나도 없는 타일(공원, 산, 건물이 모두 이웃 타일에 속하거나 너무 작은 경우)도 지형과 도로는 만들어집니다(상태 empty). 3D Tiles를 켜면 타일마다 타일셋을 쓰고, 출력 폴더 맨 위의 tileset.json이 이들을 도엽별 그룹(1:5,000, 1:50,000, 1° 블록; 실행에 필요한 만큼의 단계) 아래에 하나로 묶습니다. 그룹은 멀리서 지형과 가장 큰 건물들을 보여 줍니다(뷰어에서 열거나, QGIS 3.34 이상에서는 3D Tiles 레이어로 추가). CITYJSON을 켜면 타일마다 실행 전체에 하나인 transform으로 CityJSONSeq인 model.city.jsonl도 쓰고, 맨 위의 index.city.jsonl이 이들을 나열하는 실행의 머리 줄이 됩니다: 그 줄과 타일들의 피처를 이어 붙이면 실행 전체의 CityJSONSeq 하나가 됩니다.</translation>
    </message>
    <message>
      <source>Python interpreter of the workers (empty = found automatically)</source>
      <translation>작업자 프로세스의 Python 인터프리터 (비우면 자동으로 찾음)</translation>
    </message>
    <message>
      <source>Bounding box (instead of centre and radius)</source>
      <translation>범위 상자 (중심점과 반경 대신)</translation>
    </message>
    <message>
      <source>Everything the buildings layer covers (instead of centre and radius)</source>
      <translation>건물 레이어 전체 범위 (중심점과 반경 대신)</translation>
    </message>
    <message>
      <source>Tile grid (NGII map sheets)</source>
      <translation>타일 격자 (국토지리정보원 도엽)</translation>
    </message>
    <message>
      <source>Dask scheduler address (empty = an embedded one on this computer)</source>
      <translation>Dask 스케줄러 주소 (비우면 이 컴퓨터의 내장 스케줄러)</translation>
    </message>
    <message>
      <source>Worker processes (embedded scheduler)</source>
      <translation>작업자 프로세스 수 (내장 스케줄러)</translation>
    </message>
    <message>
      <source>Write a 3D Tiles 1.1 tileset over all tiles (tileset.json) for viewers</source>
      <translation>뷰어용 3D Tiles 1.1 타일셋을 모든 타일에 걸쳐 하나로 쓰기(tileset.json)</translation>
    </message>
    <message>
      <source>Tile index</source>
      <translation>타일 색인</translation>
    </message>
    <message>
      <source>CityJSONSeq header of the run (index.city.jsonl)</source>
      <translation>실행의 CityJSONSeq 머리 줄 (index.city.jsonl)</translation>
    </message>
    <message>
      <source>3D Tiles tileset over all tiles (tileset.json)</source>
      <translation>모든 타일을 묶은 3D Tiles 타일셋(tileset.json)</translation>
    </message>
    <message>
      <source>Tiles done</source>
      <translation>완료된 타일</translation>
    </message>
    <message>
      <source>Tiles failed</source>
      <translation>실패한 타일</translation>
    </message>
    <message>
      <source>Tiles without buildings</source>
      <translation>건물이 없는 타일</translation>
    </message>
    <message>
      <source>Tiles kept as they were (nothing they read had changed)</source>
      <translation>그대로 둔 타일 (읽는 것이 바뀌지 않음)</translation>
    </message>
    <message>
      <source>Tiles already done before this run (kept: as TILES_KEPT)</source>
      <translation>이번 실행 전에 이미 완료된 타일 (그대로 둠: TILES_KEPT와 같음)</translation>
    </message>
    <message>
      <source>Tiles built again (what they read had changed)</source>
      <translation>다시 만든 타일 (읽는 것이 바뀜)</translation>
    </message>
    <message>
      <source>Tiles new to the output</source>
      <translation>출력에 새로 생긴 타일</translation>
    </message>
    <message>
      <source>Tiles removed (they left the area)</source>
      <translation>지운 타일 (지역을 벗어남)</translation>
    </message>
    <message>
      <source>Why tiles were built again (JSON: reason → number of tiles)</source>
      <translation>타일을 다시 만든 이유 (JSON: 이유 → 타일 수)</translation>
    </message>
    <message>
      <source>1:5,000 sheets</source>
      <translation>1:5,000 도엽</translation>
    </message>
    <message>
      <source>1:1,000 sheets (dense cities)</source>
      <translation>1:1,000 도엽 (밀집 도시)</translation>
    </message>
    <message>
      <source>{failed} of {tiles} tile(s) failed. First reasons: {reasons}. The tiles done are kept in {output} (map of the run: index.gpkg); run the algorithm again on this folder to build only the others.</source>
      <translation>타일 {tiles}개 중 {failed}개가 실패했습니다. 처음 몇 가지 이유: {reasons}. 끝난 타일은 {output}에 남아 있습니다(실행 지도: index.gpkg). 이 폴더로 알고리즘을 다시 실행하면 나머지 타일만 만듭니다.</translation>
    </message>
    <message>
      <source>Cannot write {path}: {error}</source>
      <translation>{path}을(를) 쓸 수 없습니다: {error}</translation>
    </message>
    <message>
      <source>Build colour store</source>
      <translation>색상 저장소 구축</translation>
    </message>
    <message>
      <source>Texture</source>
      <translation>텍스처</translation>
    </message>
    <message>
      <source>Query colour store</source>
      <translation>색상 저장소 조회</translation>
    </message>
    <message>
      <source>RGB orthoimage</source>
      <translation>RGB 정사영상</translation>
    </message>
    <message>
      <source>Colour tolerance (RMS, 0–255)</source>
      <translation>색상 허용오차 (RMS, 0–255)</translation>
    </message>
    <message>
      <source>PostGIS connection (empty = GeoPackage)</source>
      <translation>PostGIS 연결 (비우면 GeoPackage)</translation>
    </message>
    <message>
      <source>Table</source>
      <translation>테이블</translation>
    </message>
    <message>
      <source>Colour store (GeoPackage)</source>
      <translation>색상 저장소 (GeoPackage)</translation>
    </message>
    <message>
      <source>GeoPackage (*.gpkg)</source>
      <translation>GeoPackage (*.gpkg)</translation>
    </message>
    <message>
      <source>Cells</source>
      <translation>셀 수</translation>
    </message>
    <message>
      <source>Store size (bytes)</source>
      <translation>저장소 크기 (바이트)</translation>
    </message>
    <message>
      <source>Image size (bytes)</source>
      <translation>이미지 크기 (바이트)</translation>
    </message>
    <message>
      <source>Give a GeoPackage output or a PostGIS connection.</source>
      <translation>GeoPackage 출력 또는 PostGIS 연결을 지정하십시오.</translation>
    </message>
    <message>
      <source>Colour store (GeoPackage path or PostGIS connection)</source>
      <translation>색상 저장소 (GeoPackage 경로 또는 PostGIS 연결)</translation>
    </message>
    <message>
      <source>Points to colour</source>
      <translation>색상을 구할 점</translation>
    </message>
    <message>
      <source>Patch extent</source>
      <translation>패치 범위</translation>
    </message>
    <message>
      <source>Patch resolution (m)</source>
      <translation>패치 해상도 (m)</translation>
    </message>
    <message>
      <source>Coloured points</source>
      <translation>색상이 붙은 점</translation>
    </message>
    <message>
      <source>Texture patch</source>
      <translation>텍스처 패치</translation>
    </message>
    <message>
      <source>Points coloured</source>
      <translation>색상을 구한 점 수</translation>
    </message>
    <message>
      <source>Give points to colour, a patch extent, or both.</source>
      <translation>점, 패치 범위, 또는 둘 다를 지정하십시오.</translation>
    </message>
    <message>
      <source>Export 3D Tiles</source>
      <translation>3D Tiles 내보내기</translation>
    </message>
    <message>
      <source>CityGML</source>
      <translation>CityGML</translation>
    </message>
    <message>
      <source>Writes the city model as an OGC 3D Tiles 1.1 tileset (tileset.json, glTF binary tiles and the texture images) for CesiumJS, QGIS 3.34 or later (3D Tiles layer) and other 3D Tiles viewers. Full-detail tiles hold the LoD1 buildings (roofs with the texture atlases of wit:wittexture, plain lit walls) and the terrain and roads of the TIN with their ground images, reused as they are; coarser tiles above them hold a terrain grid with its own image and the larger buildings on smaller mip levels of the atlases, so a large area streams. Coordinates are Earth-centred (from the model CRS), each tile in its own local frame. Every building carries its id and attributes (name, height, storeys, height source, source fields) as 3D Tiles metadata (EXT_mesh_features and EXT_structural_metadata): a click in a viewer shows them. The output folder is replaced whole; it must be new, empty or an earlier tileset. The web profile (off by default) quantizes the tiles' geometry and compresses it with meshoptimizer (KHR_mesh_quantization, EXT_meshopt_compression) for browsers such as CesiumJS: smaller and faster to load, but QGIS's 3D Tiles layer cannot read it; it needs the Python package meshoptimizer.</source>
      <translation>도시 모델을 OGC 3D Tiles 1.1 타일셋(tileset.json, glTF 바이너리 타일, 텍스처 이미지)으로 내보냅니다. CesiumJS, QGIS 3.34 이상(3D Tiles 레이어) 및 그 밖의 3D Tiles 뷰어에서 볼 수 있습니다. 가장 상세한 타일에는 LoD1 건물(wit:wittexture의 텍스처 아틀라스를 입힌 지붕, 음영만 준 벽면)과 TIN의 지형·도로가 지면 이미지와 함께 그대로 재사용되어 담깁니다. 그 위의 개략 타일에는 자체 이미지를 가진 지형 격자와, 아틀라스의 더 작은 밉 레벨을 입힌 큰 건물들이 담겨 넓은 지역도 스트리밍으로 볼 수 있습니다. 좌표는 모델 좌표계에서 변환한 지구 중심 좌표이며, 각 타일은 자체 지역 좌표계를 가집니다. 모든 건물은 식별자와 속성(이름, 높이, 층수, 높이 출처, 원본 필드)을 3D Tiles 메타데이터(EXT_mesh_features, EXT_structural_metadata)로 지니므로 뷰어에서 클릭하면 표시됩니다. 출력 폴더는 통째로 교체되므로 새 폴더, 빈 폴더 또는 이전에 만든 타일셋 폴더여야 합니다. 웹 프로파일(기본값은 꺼짐)은 타일의 지오메트리를 양자화하고 meshoptimizer로 압축하여(KHR_mesh_quantization, EXT_meshopt_compression) CesiumJS 같은 브라우저에서 더 작고 빠르게 불러오게 하지만, QGIS의 3D Tiles 레이어는 이를 읽을 수 없으며 파이썬 패키지 meshoptimizer가 필요합니다.</translation>
    </message>
    <message>
      <source>Side of a full-detail tile (m)</source>
      <translation>상세 타일 한 변의 길이(m)</translation>
    </message>
    <message>
      <source>Texture folder (wit:wittexture)</source>
      <translation>텍스처 폴더 (wit:wittexture)</translation>
    </message>
    <message>
      <source>Model CRS (when the layers carry none)</source>
      <translation>모델 좌표계(레이어에 좌표계가 없을 때)</translation>
    </message>
    <message>
      <source>Tileset folder</source>
      <translation>타일셋 폴더</translation>
    </message>
    <message>
      <source>tileset.json</source>
      <translation>tileset.json</translation>
    </message>
    <message>
      <source>Tiles written</source>
      <translation>작성한 타일 수</translation>
    </message>
    <message>
      <source>Size of the tileset (MB)</source>
      <translation>타일셋 크기(MB)</translation>
    </message>
    <message>
      <source>Export CityJSON 2.0</source>
      <translation>CityJSON 2.0 내보내기</translation>
    </message>
    <message>
      <source>Writes the model's layers as CityJSON 2.0 (.city.json), or as a CityJSONSeq (.city.jsonl: a header line, then one feature a line): the same objects, ids, attributes and textures as wit:writecitygml. Buildings with a LoD1 Solid whose surfaces are GroundSurface, RoofSurface and WallSurface, every source attribute, height (with heightStatus: measured or estimated) and storeys; roads as their draped triangles (TrafficArea); the other TIN triangles as one TINRelief; one CityObjectGroup per legal dong, its buildings naming it as their parent. Textures: the same images and texture coordinates, in the themes of the CityGML (rgbTexture: the orthoimage; generatedFacade: the walls' generated facades, which repeat along the wall: wrapMode wrap). Vertices are integers on the millimetre grid (transform); the CRS is the metadata's referenceSystem (an OGC CRS URL, coordinates easting first). Streaming: memory does not grow with the number of buildings. The file is written whole or not at all. Validate it with wit:validatecitygml (schemas and geometry).</source>
      <translation>모델의 레이어를 CityJSON 2.0(.city.json) 또는 CityJSONSeq(.city.jsonl: 머리 줄 다음에 한 줄에 피처 하나)로 씁니다. wit:writecitygml과 같은 객체, id, 속성, 텍스처입니다. 건물은 GroundSurface, RoofSurface, WallSurface 면을 가진 LoD1 Solid와 모든 원본 속성, 높이(heightStatus: measured 또는 estimated)와 층수를 갖고, 도로는 지형에 얹힌 삼각형(TrafficArea), 나머지 TIN 삼각형은 TINRelief 하나, 법정동마다 CityObjectGroup 하나가 되며 그 건물들은 그룹을 부모로 가리킵니다. 텍스처: 같은 이미지와 텍스처 좌표를 CityGML과 같은 테마로(rgbTexture: 정사영상; generatedFacade: 벽에 생성한 외벽 텍스처, 벽을 따라 반복: wrapMode wrap) 씁니다. 정점은 밀리미터 격자의 정수이고(transform), 좌표계는 metadata의 referenceSystem(OGC 좌표계 URL, 좌표는 동향 먼저)입니다. 스트리밍: 메모리가 건물 수에 따라 늘지 않습니다. 파일은 온전히 쓰이거나 전혀 쓰이지 않습니다. wit:validatecitygml로 검증하십시오(스키마와 기하).</translation>
    </message>
    <message>
      <source>Copy texture images beside the CityJSON file</source>
      <translation>텍스처 이미지를 CityJSON 파일 옆에 복사</translation>
    </message>
    <message>
      <source>CityJSON file</source>
      <translation>CityJSON 파일</translation>
    </message>
    <message>
      <source>CityJSON files (*.city.json);;CityJSONSeq files (*.city.jsonl)</source>
      <translation>CityJSON 파일 (*.city.json);;CityJSONSeq 파일 (*.city.jsonl)</translation>
    </message>
    <message>
      <source>Roads written</source>
      <translation>기록된 도로 수</translation>
    </message>
    <message>
      <source>Terrain triangles written</source>
      <translation>기록된 지형 삼각형 수</translation>
    </message>
    <message>
      <source>District groups</source>
      <translation>법정동 그룹 수</translation>
    </message>
    <message>
      <source>Vertices written</source>
      <translation>기록한 정점 수</translation>
    </message>
    <message>
      <source>Texture images beside the CityJSON file</source>
      <translation>CityJSON 파일 옆의 텍스처 이미지</translation>
    </message>
    <message>
      <source>The expression {expression} failed on {count} feature(s) (e.g. {error}); the next rule was used for them.</source>
      <translation>식 {expression}이(가) 피처 {count}개에서 실패했습니다(예: {error}). 해당 피처에는 다음 규칙을 적용했습니다.</translation>
    </message>
    <message>
      <source>{label}: the expression {expression} has a syntax error: {error}</source>
      <translation>{label}: 식 {expression}에 구문 오류가 있습니다: {error}</translation>
    </message>
    <message>
      <source>{label}: the expression {expression} uses the field(s) {unknown}, which the layer '{layer}' does not have; its fields are: {fields}.</source>
      <translation>{label}: 식 {expression}이(가) 레이어 '{layer}'에 없는 필드 {unknown}을(를) 사용합니다. 이 레이어의 필드: {fields}.</translation>
    </message>
    <message>
      <source>{label}: the expression {expression} fails on the first feature of '{layer}': {error}</source>
      <translation>{label}: 식 {expression}이(가) '{layer}'의 첫 번째 피처에서 실패했습니다: {error}</translation>
    </message>
    <message>
      <source>Extrude LoD1 buildings</source>
      <translation>LoD1 건물 돌출</translation>
    </message>
    <message>
      <source>Geometry</source>
      <translation>기하</translation>
    </message>
    <message>
      <source>Builds a closed, outward-oriented LoD1 solid per building: ground face, roof and one wall per footprint edge (courtyards included). The base is one height per building: the minimum of the DEM (bilinear; a DEM in another CRS is reprojected on the fly) over the footprint, so no building floats, or the median. Height: GRO_FLO_CO × storey height when the road-name-address floor count is known, else the height field, else the expression; with neither given, the height and floor fields of common layers are recognised by name (NGII digital map BFLR_CO, or 층수 as NGII ships it; building-integrated information AL_D010 A16 height, A26 floors; OpenStreetMap height, building:levels; Korean 높이, 지상층수); else the default height, which is a warning with the count. The log says which rule was used, and every building records it (wit_height_src, wit_height_rule). Output: PolygonZ faces with the building id (wit_id), face type, face number, base height, height, storeys (all derived fields named wit_…) and every source attribute under its own name.</source>
      <translation>건물마다 닫힌, 바깥을 향하는 LoD1 솔리드를 만듭니다: 바닥면, 지붕, 외곽선의 변마다 벽 하나(중정 포함). 기준 높이는 건물마다 하나입니다: 건물이 뜨지 않도록 외곽선 위 DEM(쌍선형; 다른 좌표계의 DEM은 실행 중에 바로 재투영)의 최솟값, 또는 중앙값. 높이: 도로명주소 지상층수를 알면 GRO_FLO_CO × 층고, 아니면 높이 필드, 아니면 식; 둘 다 주지 않으면 흔한 레이어의 높이·층수 필드를 이름으로 알아봅니다(국토지리정보원 수치지도 BFLR_CO, 또는 배포된 그대로의 층수; GIS건물통합정보 AL_D010 A16 높이, A26 지상층수; 오픈스트리트맵 height, building:levels; 한글 높이, 지상층수). 그래도 없으면 기본 높이를 쓰며, 그 건물 수를 경고로 알립니다. 어느 규칙을 썼는지 로그에 남기고 건물마다 기록합니다(wit_height_src, wit_height_rule). 출력: 건물 id(wit_id), 면 종류, 면 번호, 기준 높이, 높이, 층수(파생 필드는 모두 wit_… 이름)와 모든 원본 속성을 원래 이름 그대로 가진 PolygonZ 면.</translation>
    </message>
    <message>
      <source>Building footprints (any polygon layer, e.g. of wit:preparevectors)</source>
      <translation>건물 외곽선 (아무 폴리곤 레이어, 예: wit:preparevectors 출력)</translation>
    </message>
    <message>
      <source>Base height from the DEM</source>
      <translation>DEM에서 구한 밑면 높이</translation>
    </message>
    <message>
      <source>LoD1 solids (GeoPackage)</source>
      <translation>LoD1 솔리드 (GeoPackage)</translation>
    </message>
    <message>
      <source>LoD1 faces</source>
      <translation>LoD1 면</translation>
    </message>
    <message>
      <source>Solids</source>
      <translation>솔리드 수</translation>
    </message>
    <message>
      <source>Minimum on the footprint</source>
      <translation>외곽선 위 최솟값</translation>
    </message>
    <message>
      <source>Median on the footprint</source>
      <translation>외곽선 위 중앙값</translation>
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
      <source>Generates a deterministic sample of the Korean national data around a centre point: buildings (TL_SPBD_BULD), roads (TL_SPRD_MANAGE) and legal dongs (TL_SCCO_EMD) as CP949 shapefiles without .cpg in EPSG:5179 with a few real-world defects, a DEM GeoTIFF in EPSG:5186 with -9999 cells and no NoData flag, and unreferenced orthoimage TIFs named by NGII 1:5,000 map-sheet number (sheet envelope + 50 m, one brightness per tile). Set either the radius or the number of buildings (0 = from the radius).&lt;br&gt;&lt;br&gt;With a building and/or road layer given (any CRS and schema: road-name-address, NGII, OpenStreetMap; roads as centre lines, buffered by ROAD_BT / 2, else by their class width or 6 m, or as polygons), it draws the orthoimage tiles from them instead, and the DEM over their area: roofs where the footprints are, roads where the roads are, paving, lawn and forest elsewhere. The tiles are the NGII sheets that cover the study area (centre and radius, a polygon layer, or a legal dong of the district layer) clipped to the layers' extent, or that whole extent. The given layers are only read; the output folder receives the tiles, the DEM and sample_manifest.json, which names the layers they were drawn from.</source>
      <translation>중심점 주변의 국가 공간정보 형식 샘플을 항상 같은 결과로(시드 기준) 생성합니다: 건물(TL_SPBD_BULD), 도로(TL_SPRD_MANAGE), 법정동(TL_SCCO_EMD)은 .cpg 없는 CP949 셰이프파일(EPSG:5179)이며 실제 데이터에 있는 몇 가지 오류를 포함합니다. DEM은 EPSG:5186 GeoTIFF로 NoData 지정 없이 -9999 셀을 가지며, 정사영상은 NGII 1:5,000 도엽번호로 이름 붙인 좌표 없는 TIF(도엽 범위 + 50 m, 타일마다 다른 밝기)입니다. 반경 또는 건물 수(0 = 반경으로 결정) 중 하나를 지정하십시오.&lt;br&gt;&lt;br&gt;건물 또는 도로 레이어를 주면(좌표계와 스키마는 무관: 도로명주소, 국토지리정보원, OpenStreetMap. 도로는 중심선이면 ROAD_BT / 2만큼, 없으면 도로 등급별 폭이나 6 m로 버퍼하고, 폴리곤이면 그대로 씁니다) 가상 도시 대신 그 레이어로부터 정사영상 타일을 그리고, 그 영역에 DEM을 만듭니다: 건물 외곽선에는 지붕, 도로 자리에는 도로, 그 밖에는 포장면·잔디·숲을 그립니다. 타일은 연구 지역(중심과 반경, 폴리곤 레이어, 또는 법정동 레이어의 법정동)을 레이어 범위로 자른 영역, 또는 레이어 전체 범위를 덮는 NGII 도엽입니다. 주어진 레이어는 읽기만 하며, 출력 폴더에는 타일, DEM, 그리고 어느 레이어에서 그렸는지 기록한 sample_manifest.json이 생깁니다.</translation>
    </message>
    <message>
      <source>Buildings to draw the orthoimage from (empty = a synthetic city)</source>
      <translation>정사영상을 그릴 건물 (비우면 가상 도시)</translation>
    </message>
    <message>
      <source>Roads to draw the orthoimage from: centre lines or polygons</source>
      <translation>정사영상을 그릴 도로: 중심선 또는 폴리곤</translation>
    </message>
    <message>
      <source>Legal dongs (TL_SCCO_EMD), to name a district as the area</source>
      <translation>법정동(TL_SCCO_EMD): 법정동을 연구 지역으로 지정할 때</translation>
    </message>
    <message>
      <source>Draw over the whole extent of the given layers (instead of the study area)</source>
      <translation>주어진 레이어의 전체 범위에 그리기 (연구 지역 대신)</translation>
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
      <source>Generate the DEM</source>
      <translation>DEM 생성</translation>
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
      <source>Orthoimage tile folder</source>
      <translation>정사영상 타일 폴더</translation>
    </message>
    <message>
      <source>Sample manifest (JSON)</source>
      <translation>샘플 목록 (JSON)</translation>
    </message>
    <message>
      <source>Given buildings drawn</source>
      <translation>그린 건물 수</translation>
    </message>
    <message>
      <source>Given roads drawn</source>
      <translation>그린 도로 수</translation>
    </message>
    <message>
      <source>Orthoimage tiles written</source>
      <translation>생성된 정사영상 타일 수</translation>
    </message>
    <message>
      <source>A district layer, a study-area layer, a district or the whole extent apply only when drawing from a given building or road layer.</source>
      <translation>법정동 레이어, 연구 지역 레이어, 법정동 지정, 전체 범위 옵션은 건물 또는 도로 레이어로부터 그릴 때만 쓸 수 있습니다.</translation>
    </message>
    <message>
      <source>The number of buildings applies to the synthetic city only: set it to 0 when drawing from given layers.</source>
      <translation>건물 수는 가상 도시에만 적용됩니다: 주어진 레이어로부터 그릴 때는 0으로 두십시오.</translation>
    </message>
    <message>
      <source>Georeference map-sheet orthoimages</source>
      <translation>도엽 정사영상 좌표 부여</translation>
    </message>
    <message>
      <source>Rasters</source>
      <translation>래스터</translation>
    </message>
    <message>
      <source>Reads the NGII map-sheet number (도엽번호, 1:50,000 to 1:1,000) anywhere in each TIF's file name, computes the sheet's envelope in the target CRS from the sheet's degree bounds on the source datum (Korea 2000 / GRS80, EPSG:4737, by default) plus a margin (NGII tiles cover the sheet + about 50 m), and writes a georeferenced, tiled, compressed GeoTIFF — or a VRT that points at the untouched pixels. A TIF that already carries a georeference in another CRS than the target is reprojected from it instead (bilinear, its pixel size in metres). Names without a valid sheet number and files GDAL cannot open are skipped with the reason in the log and in the footprint index; nothing is guessed. Input: TIF files and/or folders (their *.tif, not recursive).</source>
      <translation>각 TIF 파일 이름의 어느 위치에서든 NGII 도엽번호(1:50,000~1:1,000)를 읽고, 원본 측지계(기본: Korea 2000 / GRS80, EPSG:4737)의 도엽 경위도 범위로부터 대상 좌표계에서의 도엽 범위를 계산한 뒤 여백(NGII 타일은 도엽 + 약 50 m)을 더해, 좌표가 부여된 타일·압축 GeoTIFF 또는 원본 픽셀을 그대로 가리키는 VRT를 씁니다. 대상 좌표계와 다른 좌표계의 지리참조를 이미 가진 TIF는 도엽번호 대신 그 지리참조로부터 재투영합니다(쌍선형, 미터 단위의 원래 픽셀 크기). 유효한 도엽번호가 없는 이름과 GDAL이 열 수 없는 파일은 건너뛰고 그 이유를 로그와 도엽 색인에 남깁니다. 추측하지 않습니다. 입력: TIF 파일 및/또는 폴더(그 안의 *.tif, 하위 폴더 제외).</translation>
    </message>
    <message>
      <source>Datum of the sheet degrees</source>
      <translation>도엽 경위도의 측지계</translation>
    </message>
    <message>
      <source>Margin around the sheet (m)</source>
      <translation>도엽 주변 여백 (m)</translation>
    </message>
    <message>
      <source>Output format</source>
      <translation>출력 형식</translation>
    </message>
    <message>
      <source>Footprint index</source>
      <translation>도엽 범위 색인</translation>
    </message>
    <message>
      <source>Georeferenced rasters</source>
      <translation>좌표 부여된 래스터</translation>
    </message>
    <message>
      <source>Sheets georeferenced</source>
      <translation>좌표 부여된 도엽 수</translation>
    </message>
    <message>
      <source>Files skipped</source>
      <translation>건너뛴 파일 수</translation>
    </message>
    <message>
      <source>Files failed</source>
      <translation>실패한 파일 수</translation>
    </message>
    <message>
      <source>GeoTIFF</source>
      <translation>GeoTIFF</translation>
    </message>
    <message>
      <source>VRT</source>
      <translation>VRT</translation>
    </message>
    <message>
      <source>Install Python dependencies</source>
      <translation>파이썬 의존 패키지 설치</translation>
    </message>
    <message>
      <source>Tools</source>
      <translation>도구</translation>
    </message>
    <message>
      <source>Installs the Python packages the algorithms need and QGIS's Python lacks (shapely 2, pythoncdt, pygltflib, Dask…; triangle, free for non-commercial use only, when you tick it) into a folder of your QGIS profile (python/wit_citymodel_deps), which the plugin puts on Python's path when it loads: no administrator rights, nothing changed outside the profile. Packages that are present already are left alone. The log shows each pip command; Cancel stops pip and installs nothing. Where QGIS's Python has no pip (Debian's and Ubuntu's QGIS do not install it), pip runs from its own wheel, downloaded from the package index pip is configured for into a work folder of the profile and deleted afterwards.&lt;br&gt;&lt;br&gt;On Linux, a shapely from PyPI carries its own GEOS and would crash QGIS: shapely is built from source against the system GEOS (that needs the GEOS development files, a C compiler and the Python headers), or, where the system offers shapely 2 (Debian testing/sid: python3-shapely), the message names the command that installs it. Restart QGIS when the log asks for it (a package that was already loaded in another version).</source>
      <translation>알고리즘에 필요하지만 QGIS의 파이썬에 없는 파이썬 패키지(shapely 2, pythoncdt, pygltflib, Dask…; 비상업적 이용에만 무료인 triangle은 선택한 경우에만)를 QGIS 프로필의 폴더(python/wit_citymodel_deps)에 설치합니다. 플러그인은 불러올 때 이 폴더를 파이썬 경로에 넣습니다. 관리자 권한이 필요 없고 프로필 밖은 아무것도 바꾸지 않습니다. 이미 있는 패키지는 그대로 둡니다. 로그에 pip 명령이 하나하나 표시되며, 취소하면 pip을 멈추고 아무것도 설치하지 않습니다. QGIS의 파이썬에 pip이 없으면(Debian과 Ubuntu의 QGIS는 pip을 설치하지 않습니다) pip이 설정된 패키지 색인에서 pip 자체의 휠을 프로필의 작업 폴더로 내려받아 그 휠로 pip을 실행하고, 끝나면 지웁니다.&lt;br&gt;&lt;br&gt;리눅스에서는 PyPI의 shapely가 자체 GEOS를 담고 있어 QGIS를 비정상 종료시킬 수 있으므로, shapely를 시스템 GEOS에 맞춰 소스에서 빌드하거나(GEOS 개발 파일, C 컴파일러, 파이썬 헤더 필요), 시스템이 shapely 2를 제공하는 경우(Debian testing/sid: python3-shapely) 이를 설치하는 명령을 메시지로 알려 줍니다. 로그가 요청하면 QGIS를 다시 시작하십시오(다른 버전이 이미 불러와진 패키지).</translation>
    </message>
    <message>
      <source>Python interpreter to run pip with (empty: QGIS's own)</source>
      <translation>pip을 실행할 파이썬 인터프리터 (비우면 QGIS의 파이썬)</translation>
    </message>
    <message>
      <source>Packages to install when missing</source>
      <translation>없으면 설치할 패키지</translation>
    </message>
    <message>
      <source>Package folder</source>
      <translation>패키지 폴더</translation>
    </message>
    <message>
      <source>Installed packages</source>
      <translation>설치한 패키지</translation>
    </message>
    <message>
      <source>Cancelled: pip was stopped and nothing was installed.</source>
      <translation>취소됨: pip을 멈췄으며 아무것도 설치하지 않았습니다.</translation>
    </message>
    <message>
      <source>Restart QGIS to use the new {modules}: this session loaded an older version.</source>
      <translation>새 {modules}을(를) 쓰려면 QGIS를 다시 시작하십시오. 이 세션은 이전 버전을 불러와 두었습니다.</translation>
    </message>
    <message>
      <source>WIT city model</source>
      <translation>WIT 도시 모델</translation>
    </message>
    <message>
      <source>Tiles of the run</source>
      <translation>실행의 타일</translation>
    </message>
    <message>
      <source>LoD1 buildings</source>
      <translation>LoD1 건물</translation>
    </message>
    <message>
      <source>Terrain (TIN)</source>
      <translation>지형(TIN)</translation>
    </message>
    <message>
      <source>3D Tiles</source>
      <translation>3D Tiles</translation>
    </message>
    <message>
      <source>Merge rasters (WIT seam feathering)</source>
      <translation>래스터 병합 (WIT 경계 보간)</translation>
    </message>
    <message>
      <source>Mosaics georeferenced tiles into one tiled, compressed GeoTIFF with internal overviews, block by block so memory does not grow with the mosaic. The output grid is the one gdal_merge.py builds (union extent, first input's pixel size). Overlap 'overwrite' lets later tiles overwrite earlier ones (the paper's method); 'feather' (WIT) blends each overlap pixel as the mean of the tiles weighted by the distance to each tile's edge. Tone correction (GAIN) equalises the tiles' tone from their overlaps: every pixel of a tile becomes gain × value + offset, per band, solved over all overlaps at once; heights (one band of floats or signed integers, a DEM) get an offset only, never a gain. NoData pixels are never blended. Inputs with another CRS or pixel size are resampled onto the first input's grid, with a warning. A mosaic that would be mostly empty (tiles far apart) is refused beyond the maximum empty share (advanced). With an extent, only the mosaic's pixels that meet it are written, with the tone and feathering of the whole mosaic.</source>
      <translation>좌표가 부여된 타일들을 블록 단위로 처리해(모자이크 크기와 무관한 메모리) 내부 피라미드가 있는 하나의 타일·압축 GeoTIFF로 병합합니다. 출력 격자는 gdal_merge.py와 같습니다(전체 범위, 첫 입력의 픽셀 크기). 겹침 '덮어쓰기'는 나중 타일이 앞 타일을 덮어씁니다(논문의 방법). '페더링'(WIT)은 겹침 픽셀을 각 타일 가장자리까지의 거리로 가중 평균합니다. 톤 보정(GAIN)은 겹침 영역으로부터 타일들의 톤을 맞춥니다. 타일의 모든 픽셀은 밴드별로 게인 × 값 + 오프셋이 되며, 모든 겹침을 한꺼번에 풀어 구합니다. 높이 자료(부동소수점 또는 부호 있는 정수의 단일 밴드, 즉 DEM)는 게인 없이 오프셋만 보정합니다. NoData 픽셀은 섞지 않습니다. 좌표계나 픽셀 크기가 다른 입력은 경고와 함께 첫 입력의 격자로 재배열합니다. 대부분이 빈 모자이크(서로 멀리 떨어진 타일)는 최대 빈 영역 비율(고급)을 넘으면 거부합니다. 범위를 주면 모자이크 중 그 범위에 닿는 화소만 쓰며, 톤 보정과 페더링은 모자이크 전체의 것을 그대로 씁니다.</translation>
    </message>
    <message>
      <source>Maximum empty share of the mosaic (%)</source>
      <translation>모자이크의 최대 빈 영역 비율 (%)</translation>
    </message>
    <message>
      <source>Input rasters</source>
      <translation>입력 래스터</translation>
    </message>
    <message>
      <source>Overlap</source>
      <translation>겹침 처리</translation>
    </message>
    <message>
      <source>Equalise tile tone (gain and offset; with feather)</source>
      <translation>타일 톤 맞춤 (게인과 오프셋, 페더링과 함께)</translation>
    </message>
    <message>
      <source>NoData value of the inputs (empty = as declared)</source>
      <translation>입력의 NoData 값 (비우면 파일에 선언된 값)</translation>
    </message>
    <message>
      <source>Write only this extent of the mosaic (empty = all of it)</source>
      <translation>모자이크 중 이 범위만 쓰기(비우면 전체)</translation>
    </message>
    <message>
      <source>Mosaic</source>
      <translation>모자이크</translation>
    </message>
    <message>
      <source>Blended pixels</source>
      <translation>보간된 픽셀 수</translation>
    </message>
    <message>
      <source>Overwrite (paper)</source>
      <translation>덮어쓰기 (논문)</translation>
    </message>
    <message>
      <source>Feather (WIT)</source>
      <translation>페더링 (WIT)</translation>
    </message>
    <message>
      <source>Prepare vector layers</source>
      <translation>벡터 레이어 준비</translation>
    </message>
    <message>
      <source>Reads the building (TL_SPBD_BULD, NGII N3A_B0010000, AL_D010, OpenStreetMap…), road and legal-dong (TL_SCCO_EMD) layers — any layer of the right geometry type; shapefiles are read in their text's encoding (the .cpg's when it fits the text, else CP949 or UTF-8 as the text shows), field names included — reprojects them (EPSG:5186 by default), repairs them (closes rings, orients exteriors counter-clockwise and holes clockwise, makes them valid, removes duplicate vertices, drops slivers, features with infinite or NaN coordinates and exact duplicates (same id and footprint) with the reason and a count; the same id on different footprints gets _2, _3… on its wit_id), clips them to the study area and simplifies them with Douglas–Peucker (buildings 0.5 m, roads and districts 5 m by default) so that polygons stay valid and buildings sharing a wall still share it. Road polygons (NGII N3A_A0010000) are the road surfaces as they are; centre lines become polygons buffered by width / 2, the width from the layer's width field (ROAD_BT, NGII 도로폭 / RVWD, OpenStreetMap width), else its lanes × 3.25 m (CARTRK_CO, 차로수, RDLN, lanes), else its class (ROA_CLS_SE, highway), else the default width; the log names the rule and counts. Study area: a legal-dong code if given, else a polygon layer if given, else the centre point and radius. Writes one GeoPackage (buildings, roads, districts, stats, dropped) and a stats CSV: features in/out, repairs, drops and vertices per layer.</source>
      <translation>건물(TL_SPBD_BULD, 국토지리정보원 N3A_B0010000, AL_D010, 오픈스트리트맵…), 도로, 법정동(TL_SCCO_EMD) 레이어를 읽습니다(도형 유형만 맞으면 어떤 레이어든; 셰이프파일은 내용의 인코딩으로 읽음: .cpg가 내용과 맞으면 그것, 아니면 내용에 따라 CP949나 UTF-8, 필드 이름 포함). 좌표계를 변환하고(기본 EPSG:5186) 오류를 고칩니다(링 닫기, 외곽은 반시계·구멍은 시계 방향, 유효화, 중복 꼭짓점 제거. 가는 조각, 무한대나 NaN 좌표가 있는 피처, 완전히 같은 중복 피처(같은 ID와 외곽선)는 이유와 개수를 남기고 제외하며, ID가 같지만 외곽선이 다른 피처는 wit_id에 _2, _3…을 붙여 모두 남김). 연구 지역으로 자르고 Douglas–Peucker로 단순화합니다(기본: 건물 0.5 m, 도로·행정구역 5 m). 폴리곤은 유효하게 유지되고 벽을 공유하던 건물은 계속 공유합니다. 도로 폴리곤(국토지리정보원 N3A_A0010000)은 그대로 도로면이 되고, 중심선은 폭 / 2 만큼 버퍼한 폴리곤이 됩니다. 폭은 레이어의 폭 필드(ROAD_BT, 국토지리정보원 도로폭 / RVWD, 오픈스트리트맵 width), 없으면 차로수 × 3.25 m(CARTRK_CO, 차로수, RDLN, lanes), 없으면 등급(ROA_CLS_SE, highway), 없으면 기본 폭이며, 어느 규칙을 썼는지와 개수를 로그에 남깁니다. 연구 지역: 법정동 코드가 있으면 그것, 없으면 폴리곤 레이어, 없으면 중심점과 반경. 하나의 GeoPackage(buildings, roads, districts, stats, dropped)와 통계 CSV(레이어별 입력/출력 수, 수정, 제외, 꼭짓점 수)를 씁니다.</translation>
    </message>
    <message>
      <source>Douglas–Peucker tolerance, buildings (m)</source>
      <translation>Douglas–Peucker 허용오차, 건물 (m)</translation>
    </message>
    <message>
      <source>Douglas–Peucker tolerance, roads (m)</source>
      <translation>Douglas–Peucker 허용오차, 도로 (m)</translation>
    </message>
    <message>
      <source>Douglas–Peucker tolerance, districts (m)</source>
      <translation>Douglas–Peucker 허용오차, 행정구역 (m)</translation>
    </message>
    <message>
      <source>Minimum building area (m²)</source>
      <translation>최소 건물 면적 (m²)</translation>
    </message>
    <message>
      <source>Road width when a centre line has no width, lanes or class (m)</source>
      <translation>중심선에 폭·차로수·등급이 없을 때 도로 폭 (m)</translation>
    </message>
    <message>
      <source>Shapefile text encoding (empty = detect; CP949 for juso.go.kr files)</source>
      <translation>셰이프파일 문자 인코딩 (비우면 자동 감지, juso.go.kr 파일은 CP949)</translation>
    </message>
    <message>
      <source>Prepared layers (GeoPackage)</source>
      <translation>준비된 레이어 (GeoPackage)</translation>
    </message>
    <message>
      <source>Prepared buildings</source>
      <translation>준비된 건물</translation>
    </message>
    <message>
      <source>Prepared road polygons</source>
      <translation>준비된 도로 폴리곤</translation>
    </message>
    <message>
      <source>Prepared legal dongs</source>
      <translation>준비된 법정동</translation>
    </message>
    <message>
      <source>Study area</source>
      <translation>연구 지역</translation>
    </message>
    <message>
      <source>Statistics (CSV)</source>
      <translation>통계 (CSV)</translation>
    </message>
    <message>
      <source>Buildings kept</source>
      <translation>유지된 건물 수</translation>
    </message>
    <message>
      <source>Give at least one of the building, road and district layers.</source>
      <translation>건물, 도로, 법정동 레이어 중 적어도 하나를 지정하십시오.</translation>
    </message>
    <message>
      <source>City model (graphical model)</source>
      <translation>도시모델 (그래픽 모델)</translation>
    </message>
    <message>
      <source>WIT City Model: textured CityGML 3.0 from Korean national GIS data</source>
      <translation>WIT 도시모델: 국가 공간정보로 텍스처 CityGML 3.0 생성</translation>
    </message>
    <message>
      <source>Quality metrics</source>
      <translation>품질 지표</translation>
    </message>
    <message>
      <source>Measures the model against its sources, as the paper's Tables 17 and 19 (paper figures beside ours). Geometry (the CityGML file or the LoD1 layer against the prepared 2D footprints, matched by wit_id): placement error = distance between the centroids of footprint and ground face; coordinate error = each roof vertex to the nearest footprint vertex (mean, max); Hausdorff distance of the outlines; shape similarity index SSI = area(A∩B) / area(A∪B) (intersection over union) of footprint and ground face. Texture: sharpness = variance of the 4-neighbour Laplacian of the grey image (0.299R + 0.587G + 0.114B, as OpenCV's Laplacian().var()) and contrast = standard deviation of the grey values, on the texture images (inside the texture islands) and on the orthoimage for comparison. Seams: mean colour step across tile borders in the mosaic. Writes a CSV table, per-building rows, a GeoPackage and an HTML report.</source>
      <translation>논문의 표 17과 19처럼 모델을 원본과 비교해 측정합니다(논문 수치를 함께 표시). 기하(CityGML 파일 또는 LoD1 레이어를 준비된 2D 외곽선과 wit_id로 대응): 배치 오차 = 외곽선과 바닥면 중심 사이 거리, 좌표 오차 = 각 지붕 꼭짓점에서 가장 가까운 외곽선 꼭짓점까지(평균, 최대), 외곽선의 하우스도르프 거리, 형상 유사도 SSI = 외곽선과 바닥면의 면적(A∩B) / 면적(A∪B)(IoU). 텍스처: 선명도 = 회색 영상(0.299R + 0.587G + 0.114B)의 4-이웃 라플라시안 분산(OpenCV Laplacian().var()와 같음), 대비 = 회색 값의 표준편차; 텍스처 이미지(텍스처 섬 내부)와 비교용 정사영상에서 계산. 경계: 모자이크에서 타일 경계를 가로지르는 평균 색상 차. CSV 표, 건물별 행, GeoPackage, HTML 보고서를 씁니다.</translation>
    </message>
    <message>
      <source>Model: CityGML file or LoD1 GeoPackage</source>
      <translation>모델: CityGML 파일 또는 LoD1 GeoPackage</translation>
    </message>
    <message>
      <source>2D source footprints (prepared buildings)</source>
      <translation>2D 원본 외곽선 (준비된 건물)</translation>
    </message>
    <message>
      <source>Orthoimage for comparison</source>
      <translation>비교용 정사영상</translation>
    </message>
    <message>
      <source>Merged mosaic (seam step)</source>
      <translation>병합 모자이크 (경계 단차)</translation>
    </message>
    <message>
      <source>Tile footprints (index of wit:georeferencemapsheets)</source>
      <translation>타일 범위 (wit:georeferencemapsheets 색인)</translation>
    </message>
    <message>
      <source>CSV files (*.csv)</source>
      <translation>CSV 파일 (*.csv)</translation>
    </message>
    <message>
      <source>HTML report</source>
      <translation>HTML 보고서</translation>
    </message>
    <message>
      <source>HTML files (*.html)</source>
      <translation>HTML 파일 (*.html)</translation>
    </message>
    <message>
      <source>Mean placement error (m)</source>
      <translation>평균 배치 오차 (m)</translation>
    </message>
    <message>
      <source>Maximum coordinate error (m)</source>
      <translation>최대 좌표 오차 (m)</translation>
    </message>
    <message>
      <source>Mean shape similarity (IoU)</source>
      <translation>평균 형상 유사도 (IoU)</translation>
    </message>
    <message>
      <source>Texture sharpness (Laplacian variance)</source>
      <translation>텍스처 선명도 (라플라시안 분산)</translation>
    </message>
    <message>
      <source>Texture contrast (grey std)</source>
      <translation>텍스처 대비 (회색 표준편차)</translation>
    </message>
    <message>
      <source>Seam step across tile borders</source>
      <translation>타일 경계 단차</translation>
    </message>
    <message>
      <source>points</source>
      <translation>점</translation>
    </message>
    <message>
      <source>lines</source>
      <translation>선</translation>
    </message>
    <message>
      <source>polygons</source>
      <translation>폴리곤</translation>
    </message>
    <message>
      <source>no geometry</source>
      <translation>도형 없음</translation>
    </message>
    <message>
      <source>{label}: the layer '{layer}' ({source}) has {found} ({wkb}); expected {wanted}.</source>
      <translation>{label}: 레이어 '{layer}'({source})의 도형은 {found}({wkb})입니다. 필요한 도형: {wanted}.</translation>
    </message>
    <message>
      <source>The output '{output}' ({output_path}) would overwrite the input '{input}' ({input_path}){via}: choose another output name or folder. Nothing was written.</source>
      <translation>출력 '{output}'({output_path})이(가) 입력 '{input}'({input_path})을(를) 덮어쓰게 됩니다{via}. 다른 출력 이름이나 폴더를 고르십시오. 아무것도 쓰지 않았습니다.</translation>
    </message>
    <message>
      <source>The output folder '{output}' ({output_path}) holds the input '{input}' ({input_path}): choose an output folder that holds none of the inputs. Nothing was written.</source>
      <translation>출력 폴더 '{output}'({output_path}) 안에 입력 '{input}'({input_path})이(가) 있습니다. 입력이 하나도 들어 있지 않은 출력 폴더를 고르십시오. 아무것도 쓰지 않았습니다.</translation>
    </message>
    <message>
      <source> (through {file})</source>
      <translation> ({file}을(를) 통해)</translation>
    </message>
    <message>
      <source>unknown geometries</source>
      <translation>알 수 없는 도형</translation>
    </message>
    <message>
      <source> or </source>
      <translation> 또는 </translation>
    </message>
    <message>
      <source>Roads: centre lines or road polygons (TL_SPRD_MANAGE, NGII N3L_A0020000 or N3A_A0010000, OpenStreetMap…)</source>
      <translation>도로: 중심선 또는 도로 폴리곤 (TL_SPRD_MANAGE, 국토지리정보원 N3L_A0020000 또는 N3A_A0010000, 오픈스트리트맵…)</translation>
    </message>
    <message>
      <source>Triangle (non-commercial licence)</source>
      <translation>Triangle (비상업적 이용 라이선스)</translation>
    </message>
    <message>
      <source>CDT (MPL-2.0)</source>
      <translation>CDT (MPL-2.0)</translation>
    </message>
    <message>
      <source>None: plain walls</source>
      <translation>없음: 민무늬 벽</translation>
    </message>
    <message>
      <source>Generated from each building's use and storeys (marked as generated)</source>
      <translation>각 건물의 용도와 층수로 생성(생성된 것임을 표시)</translation>
    </message>
    <message>
      <source>3D Tiles web profile: compressed geometry for browsers (QGIS cannot read it)</source>
      <translation>3D Tiles 웹 프로파일: 브라우저용 압축 지오메트리 (QGIS에서는 읽을 수 없음)</translation>
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
      <source>Study area polygons (instead of centre and radius)</source>
      <translation>연구 지역 폴리곤 (중심·반경 대신)</translation>
    </message>
    <message>
      <source>Legal dong: code (EMD_CD) or name, e.g. 11680101 or 역삼동 (instead of centre and radius)</source>
      <translation>법정동: 코드(EMD_CD) 또는 이름, 예: 11680101 또는 역삼동 (중심점과 반경 대신)</translation>
    </message>
    <message>
      <source>Triangulator (licence: Triangle is free for non-commercial use only)</source>
      <translation>삼각분할 라이브러리 (라이선스: Triangle은 비상업적 이용에만 무료)</translation>
    </message>
    <message>
      <source>Maximum edge length (m)</source>
      <translation>최대 변 길이 (m)</translation>
    </message>
    <message>
      <source>Vertical tolerance (m)</source>
      <translation>수직 허용오차 (m)</translation>
    </message>
    <message>
      <source>Triangle (package 'triangle') is not installed: the terrain is meshed with CDT (MPL-2.0).</source>
      <translation>Triangle('triangle' 패키지)이 설치되어 있지 않습니다: 지형은 CDT(MPL-2.0)로 삼각분할합니다.</translation>
    </message>
    <message>
      <source>Storey height (m)</source>
      <translation>층고 (m)</translation>
    </message>
    <message>
      <source>Height field (m), when floors are unknown (empty = recognised by name)</source>
      <translation>높이 필드 (m), 층수를 모를 때 (비우면 이름으로 인식)</translation>
    </message>
    <message>
      <source>Height expression (m), when floors and field are unknown</source>
      <translation>높이 표현식 (m), 층수와 필드를 모를 때</translation>
    </message>
    <message>
      <source>Default height (m)</source>
      <translation>기본 높이 (m)</translation>
    </message>
    <message>
      <source>LoD1 buildings (wit:extrudebuildings)</source>
      <translation>LoD1 건물 (wit:extrudebuildings)</translation>
    </message>
    <message>
      <source>Terrain TIN (wit:triangulateterrain)</source>
      <translation>지형 TIN (wit:triangulateterrain)</translation>
    </message>
    <message>
      <source>Road polygons (wit:preparevectors)</source>
      <translation>도로 폴리곤 (wit:preparevectors)</translation>
    </message>
    <message>
      <source>Legal dongs (wit:preparevectors)</source>
      <translation>법정동 (wit:preparevectors)</translation>
    </message>
    <message>
      <source>Wall textures (an orthoimage sees no facades)</source>
      <translation>벽 텍스처(정사영상에는 벽면이 보이지 않음)</translation>
    </message>
    <message>
      <source>Write CityJSON 2.0 beside the CityGML (model.city.json; a tiled run: a CityJSONSeq per tile and index.city.jsonl)</source>
      <translation>CityGML 옆에 CityJSON 2.0도 쓰기 (model.city.json; 타일 실행: 타일마다 CityJSONSeq와 index.city.jsonl)</translation>
    </message>
    <message>
      <source>Build everything again, even what has not changed since the last run into this folder</source>
      <translation>이 폴더에 대한 지난 실행 이후 바뀌지 않은 것까지 모두 다시 만들기</translation>
    </message>
    <message>
      <source>Code field of the district layer (empty = EMD_CD)</source>
      <translation>법정동 레이어의 코드 필드 (비우면 EMD_CD)</translation>
    </message>
    <message>
      <source>Name field of the district layer (empty = EMD_KOR_NM, EMD_ENG_NM)</source>
      <translation>법정동 레이어의 이름 필드 (비우면 EMD_KOR_NM, EMD_ENG_NM)</translation>
    </message>
    <message>
      <source>Triangulate terrain (constrained Delaunay)</source>
      <translation>지형 삼각분할 (제약 들로네)</translation>
    </message>
    <message>
      <source>Meshes the study area with a constrained Delaunay triangulation (library: Triangle, free for non-commercial use only, or CDT, MPL-2.0, free for commercial use too; the same checks whichever): building footprints and road polygons are constraints whose edges appear in the mesh; footprints become holes (buildings stand on them) or constrained edges. Edges are at most the maximum edge length (paper: 5 m), and the mesh is refined where the DEM surface departs from the TIN by more than the vertical tolerance (a rigorous bound clears most triangles; the others are measured exactly along every edge and at the DEM cell centres inside, and so is the reported maximum). Heights: bilinear interpolation of the four surrounding DEM cell centres (a DEM in another CRS than the layers' is reprojected on the fly to theirs, bilinear, on a grid of its own cell size, and the tolerance is measured against that surface); DEM NoData (declared, or ≤ −1000 when none is declared) is filled from neighbours, never used. Messy constraints (duplicates, crossings, slivers) are cleaned first so the triangulator cannot crash. Output: one PolygonZ triangle per feature (tri_id, surface: terrain/road/footprint, feature_id), plus counts and the measured maximum vertical error.</source>
      <translation>연구 지역을 제약 들로네 삼각분할로 메시화합니다(라이브러리: 비상업적 이용에만 무료인 Triangle, 또는 상업적 이용도 무료인 CDT(MPL-2.0); 어느 쪽이든 같은 검사): 건물 외곽선과 도로 폴리곤이 제약이 되어 그 변이 메시에 나타나며, 외곽선은 구멍(건물이 그 위에 섬) 또는 제약 변이 됩니다. 변 길이는 최대 변 길이(논문: 5 m) 이하이며, DEM 표면이 TIN에서 수직 허용오차보다 멀어지는 곳은 세분합니다(엄밀한 상한으로 대부분의 삼각형을 확인하고, 나머지는 모든 변과 내부의 DEM 셀 중심에서 정확히 측정하며, 보고하는 최대값도 정확한 값입니다). 높이: 주변 네 DEM 셀 중심의 쌍선형 보간(레이어와 다른 좌표계의 DEM은 실행 중에 레이어의 좌표계로 재투영하며—쌍선형, 원래 셀 크기의 격자—허용오차는 그 표면에 대해 잽니다). DEM NoData(선언된 값, 선언이 없으면 −1000 이하)는 이웃으로 채우며 높이로 쓰지 않습니다. 삼각분할기가 멈추지 않도록 지저분한 제약(중복, 교차, 가는 조각)을 먼저 정리합니다. 출력: 삼각형마다 하나의 PolygonZ 피처(tri_id, surface: terrain/road/footprint, feature_id), 개수와 측정된 최대 수직 오차.</translation>
    </message>
    <message>
      <source>Study area (polygon layer, e.g. study_area of wit:preparevectors)</source>
      <translation>연구 지역 (폴리곤 레이어, 예: wit:preparevectors의 study_area)</translation>
    </message>
    <message>
      <source>Building footprints (constraints)</source>
      <translation>건물 외곽선 (제약)</translation>
    </message>
    <message>
      <source>Road polygons (constraints)</source>
      <translation>도로 폴리곤 (제약)</translation>
    </message>
    <message>
      <source>Building footprints become</source>
      <translation>건물 외곽선 처리</translation>
    </message>
    <message>
      <source>TIN (GeoPackage)</source>
      <translation>TIN (GeoPackage)</translation>
    </message>
    <message>
      <source>TIN triangles</source>
      <translation>TIN 삼각형</translation>
    </message>
    <message>
      <source>Triangles</source>
      <translation>삼각형 수</translation>
    </message>
    <message>
      <source>Measured maximum vertical error (m)</source>
      <translation>측정된 최대 수직 오차 (m)</translation>
    </message>
    <message>
      <source>Measured maximum edge length (m)</source>
      <translation>측정된 최대 변 길이 (m)</translation>
    </message>
    <message>
      <source>Holes (buildings stand on them)</source>
      <translation>구멍 (건물이 그 위에 섬)</translation>
    </message>
    <message>
      <source>Constrained edges</source>
      <translation>제약 변</translation>
    </message>
    <message>
      <source>Validate CityGML 3.0</source>
      <translation>CityGML 3.0 검증</translation>
    </message>
    <message>
      <source>Validates CityGML 3.0 files offline and reports every problem with file, line and gml:id: XSD validity against all CityGML 3.0 modules (a file using an ADE whose schema is missing is reported as such), unique gml:id, every #id / xlink:href reference resolves, building solids closed, consistently outward-oriented, with planar and non-self-intersecting faces, TIN triangles non-degenerate, all positions 3D, texture images present and texture coordinates matching their rings. Geometric tolerances are in metres whatever the CRS: coordinates in degrees (e.g. EPSG:4326, EPSG:6697) are measured in local metres; an unknown CRS is read as metres, with a warning. Axis order as GDAL reads it: the short form EPSG:n is longitude (easting) first, the URN and URL forms follow EPSG's order (latitude or northing first for EPSG:4326, 6697, 5186…); latitudes beyond ±90° are read swapped, with a warning. A file that is empty, not XML, not CityGML 3.0 or truncated gets one message saying so. CityJSON 2.0 files (.city.json) and CityJSONSeq files (.city.jsonl) are validated alike: against the official CityJSON 2.0 schemas the plugin ships, and with the same checks and tolerances (ids, parents and children, vertex indices, solids, TIN triangles, texture images and values); a tile's sequence of a tiled run finds its images from the run's folder. Large files are streamed. External entities and network access are disabled while parsing. Schemas: the SCHEMA_DIR folder (an override, e.g. for an ADE), else the folder set in the plugin settings, else the CityGML 3.0 schemas the plugin ships (no network needed); the log says which was used. Results: VALID, ERROR_COUNT and a per-file table (file, status, details) as in the paper's Table 13, plus HTML and CSV reports (the HTML report goes to a temporary file when none is chosen).</source>
      <translation>CityGML 3.0 파일을 오프라인으로 검증하고 모든 문제를 파일, 줄, gml:id와 함께 보고합니다: 모든 CityGML 3.0 모듈에 대한 XSD 유효성(스키마가 없는 ADE를 쓰는 파일은 그렇다고 보고), gml:id 중복 없음, 모든 #id / xlink:href 참조 해석, 건물 솔리드가 닫혀 있고 일관되게 바깥을 향하며 면이 평면이고 자기 교차가 없음, TIN 삼각형이 퇴화하지 않음, 모든 좌표가 3차원, 텍스처 이미지 존재 및 텍스처 좌표 수가 링과 일치. 기하 허용 오차는 좌표계와 관계없이 미터 단위입니다: 도 단위 좌표(예: EPSG:4326, EPSG:6697)는 국지 미터 좌표로 환산해 재며, 알 수 없는 좌표계는 미터로 보고 경고를 남깁니다. 축 순서는 GDAL이 읽는 방식을 따릅니다: 짧은 형식 EPSG:n은 경도(동향) 먼저, URN과 URL 형식은 EPSG의 순서(EPSG:4326, 6697, 5186 등은 위도 또는 북향 먼저)입니다. ±90°를 넘는 위도는 축을 바꿔 읽고 경고를 남깁니다. 비어 있거나, XML이 아니거나, CityGML 3.0이 아니거나, 중간에 잘린 파일은 그 사실을 알리는 메시지 하나로 보고합니다. CityJSON 2.0 파일(.city.json)과 CityJSONSeq 파일(.city.jsonl)도 같은 방식으로 검증합니다: 플러그인에 포함된 공식 CityJSON 2.0 스키마와, 같은 검사와 허용 오차(id, parents와 children, 정점 색인, 솔리드, TIN 삼각형, 텍스처 이미지와 값)로. 타일 실행의 타일 시퀀스는 실행 폴더에서 이미지를 찾습니다. 큰 파일은 스트리밍으로 처리합니다. 파싱 중 외부 엔티티와 네트워크 접근은 꺼져 있습니다. 스키마: SCHEMA_DIR 폴더(예: ADE용으로 덮어쓰기), 없으면 플러그인 설정의 폴더, 없으면 플러그인에 포함된 CityGML 3.0 스키마(네트워크 불필요). 어느 것을 썼는지 로그에 남깁니다. 결과: VALID, ERROR_COUNT, 논문 표 13과 같은 파일별 표(파일, 상태, 상세), HTML 및 CSV 보고서(HTML 보고서를 지정하지 않으면 임시 파일에 씁니다).</translation>
    </message>
    <message>
      <source>CityGML or CityJSON files</source>
      <translation>CityGML 또는 CityJSON 파일</translation>
    </message>
    <message>
      <source>Schema folder (with citygml3-all.xsd)</source>
      <translation>스키마 폴더 (citygml3-all.xsd 포함)</translation>
    </message>
    <message>
      <source>CSV report (one row per problem)</source>
      <translation>CSV 보고서 (문제마다 한 행)</translation>
    </message>
    <message>
      <source>Validation table</source>
      <translation>검증 결과 표</translation>
    </message>
    <message>
      <source>Schemas used</source>
      <translation>사용한 스키마</translation>
    </message>
    <message>
      <source>Schemas: {source} ({folder})</source>
      <translation>스키마: {source} ({folder})</translation>
    </message>
    <message>
      <source>WIT texturing</source>
      <translation>WIT 텍스처링</translation>
    </message>
    <message>
      <source>Cuts textures for roofs (LoD1 roof faces), terrain and road triangles (TIN) from the merged orthoimage. Texture coordinates follow U = (x − xmin)/(xmax − xmin), V = (y − ymin)/(ymax − ymin) over each image's ground extent with the half-pixel correction, so a vertex at a pixel centre lands on that pixel's texel centre. Roofs are packed into atlases with gutters (edge pixels repeated) so that mipmaps do not bleed neighbours in; terrain and roads use one image per ground square. An orthoimage sees no facades: walls get generated facades (FACADES, the default), storey modules drawn by the plugin for each building's use (the national use code BDTYP_CD, NGII's 용도/종류, AL_D010, OpenStreetMap's building tag, else its storeys) with one image row per storey (the layer's floor count, else its height), kept apart and marked as generated (facades.gpkg, the CityGML theme generatedFacade); or none. Scale S (0 &lt; S ≤ 1) sets the resolution; the mip chain down to 1×1 can be written too. The orthoimage is read in windows, never whole; one in another CRS than the layers is reprojected as it is read (bilinear). Output: a folder of images and texcoords.gpkg, the input of wit:writecitygml.</source>
      <translation>정사영상에서 지붕(LoD1 지붕 면), 지형 및 도로 삼각형(TIN)의 텍스처를 잘라냅니다. 텍스처 좌표는 각 이미지의 지상 범위에 대해 U = (x − xmin)/(xmax − xmin), V = (y − ymin)/(ymax − ymin)이며 반 픽셀 보정을 하므로 픽셀 중심의 꼭짓점은 그 픽셀 텍셀의 중심에 놓입니다. 지붕은 거터(가장자리 픽셀 반복)를 둔 아틀라스에 배치되어 밉맵에서 이웃이 번지지 않으며, 지형과 도로는 지상 정사각형 구역마다 한 이미지를 씁니다. 정사영상에는 벽면이 보이지 않으므로 벽에는 생성된 외벽 텍스처를 입힙니다(FACADES, 기본값): 각 건물의 용도(국가 건축물 용도코드 BDTYP_CD, 국토지리정보원의 용도/종류, AL_D010, OpenStreetMap building 태그, 없으면 층수)에 맞는 층 모듈을 플러그인이 직접 그리며, 층마다 이미지 한 줄(레이어의 층수, 없으면 높이로 계산)에 대응하고, 측정값과 분리해 생성된 것임을 표시합니다(facades.gpkg, CityGML 테마 generatedFacade). 없음을 고를 수도 있습니다. 배율 S(0 &lt; S ≤ 1)가 해상도를 정하며, 1×1까지의 밉 체인도 쓸 수 있습니다. 정사영상은 전체가 아니라 창 단위로 읽으며, 레이어와 다른 좌표계의 정사영상은 읽는 대로 재투영합니다(쌍선형). 출력: 이미지 폴더와 texcoords.gpkg(wit:writecitygml의 입력).</translation>
    </message>
    <message>
      <source>Merged orthoimage</source>
      <translation>병합된 정사영상</translation>
    </message>
    <message>
      <source>Image format</source>
      <translation>이미지 형식</translation>
    </message>
    <message>
      <source>JPEG quality</source>
      <translation>JPEG 품질</translation>
    </message>
    <message>
      <source>Atlas size limit (px)</source>
      <translation>아틀라스 최대 크기 (px)</translation>
    </message>
    <message>
      <source>Gutter width (px)</source>
      <translation>거터 폭 (px)</translation>
    </message>
    <message>
      <source>Write the mip chain (to 1×1)</source>
      <translation>밉 체인 쓰기 (1×1까지)</translation>
    </message>
    <message>
      <source>Texture folder</source>
      <translation>텍스처 폴더</translation>
    </message>
    <message>
      <source>Images written</source>
      <translation>기록된 이미지 수</translation>
    </message>
    <message>
      <source>Textured surfaces</source>
      <translation>텍스처가 입혀진 면 수</translation>
    </message>
    <message>
      <source>Buildings with a generated facade</source>
      <translation>생성된 외벽 텍스처를 받은 건물</translation>
    </message>
    <message>
      <source>Give the LoD1 buildings, the TIN, or both.</source>
      <translation>LoD1 건물, TIN, 또는 둘 다를 지정하십시오.</translation>
    </message>
    <message>
      <source>Write CityGML 3.0</source>
      <translation>CityGML 3.0 쓰기</translation>
    </message>
    <message>
      <source>Writes a CityGML 3.0 city model, streaming (memory does not grow with the number of buildings): bldg:Building with a closed, outward-oriented lod1Solid, con:height, storeys and every source attribute as a typed generic attribute (from wit:extrudebuildings); tran:Road with traffic areas draped on the terrain and dem:ReliefFeature with a TIN (from wit:triangulateterrain, with the prepared roads' attributes); one grp:CityObjectGroup per legal dong (districts); and, when given, the textures of wit:wittexture as app:ParameterizedTexture (images copied beside the .gml, relative image URIs). gml:ids derive from the source ids, so the same input gives the same ids. srsName: EPSG:n, coordinates easting first, as GIS software reads that form. Runs in the main thread.</source>
      <translation>CityGML 3.0 도시모델을 스트리밍으로 씁니다(건물 수가 늘어도 메모리가 늘지 않음): 닫혀 있고 바깥을 향하는 lod1Solid, con:height, 층수, 모든 원본 속성을 형식 있는 일반 속성으로 가진 bldg:Building(wit:extrudebuildings에서), 지형 위에 놓인 통행 영역을 가진 tran:Road와 TIN을 가진 dem:ReliefFeature(wit:triangulateterrain에서, 준비된 도로 속성 포함), 법정동마다 하나의 grp:CityObjectGroup(행정구역), 그리고 있으면 wit:wittexture의 텍스처를 app:ParameterizedTexture로(이미지는 .gml 옆에 복사, 상대 경로 URI). gml:id는 원본 ID에서 만들어지므로 같은 입력은 같은 ID를 줍니다. srsName은 EPSG:n이고 좌표는 GIS 소프트웨어가 이 형식을 읽는 대로 동향 먼저입니다. 메인 스레드에서 실행됩니다.</translation>
    </message>
    <message>
      <source>Copy texture images beside the .gml</source>
      <translation>텍스처 이미지를 .gml 옆에 복사</translation>
    </message>
    <message>
      <source>CityGML files (*.gml)</source>
      <translation>CityGML 파일 (*.gml)</translation>
    </message>
    <message>
      <source>Texture images beside the CityGML file</source>
      <translation>CityGML 파일 옆의 텍스처 이미지</translation>
    </message>
    <message>
      <source>triangle (J. R. Shewchuk's Triangle) is free for non-commercial use only; commercial use needs a licence from its author.</source>
      <translation>triangle(J. R. Shewchuk의 Triangle)은 비상업적 용도로만 무료이며, 상업적으로 사용하려면 저작자의 라이선스가 필요합니다.</translation>
    </message>
    <message>
      <source>Missing: {names}.</source>
      <translation>없는 패키지: {names}.</translation>
    </message>
    <message>
      <source>Installed into {folder}: {packages}.</source>
      <translation>{folder}에 설치함: {packages}.</translation>
    </message>
    <message>
      <source>QGIS's Python ({python}) has no pip, and pip's own wheel could not be fetched from the package index ({reason}): {command}</source>
      <translation>QGIS의 파이썬({python})에 pip이 없고, 패키지 색인에서 pip 자체의 휠도 받아 오지 못했습니다({reason}): {command}</translation>
    </message>
    <message>
      <source>QGIS's Python has no pip that can install: pip {version} runs from its own wheel, downloaded from {url}.</source>
      <translation>QGIS의 파이썬에 설치에 쓸 수 있는 pip이 없어, {url}에서 내려받은 pip {version} 자체의 휠로 pip을 실행합니다.</translation>
    </message>
    <message>
      <source>Run: {command}</source>
      <translation>실행: {command}</translation>
    </message>
    <message>
      <source>shapely: a shapely wheel bundles its own GEOS, which crashes QGIS on Linux; it must be built against the system GEOS, which needs the GEOS development files, a C compiler and the Python headers ({packages}).</source>
      <translation>shapely: shapely 휠은 자체 GEOS를 담고 있어 리눅스에서 QGIS를 비정상 종료시키므로 시스템 GEOS에 맞춰 빌드해야 하며, 이를 위해 GEOS 개발 파일, C 컴파일러, 파이썬 헤더({packages})가 필요합니다.</translation>
    </message>
    <message>
      <source>Every selected package is present already: {names}.</source>
      <translation>선택한 패키지가 모두 이미 있습니다: {names}.</translation>
    </message>
    <message>
      <source>QGIS's Python ({python}) has pip {version}; installing needs pip 22.2 or later, and pip's own wheel could not be fetched from the package index ({reason}): {command}</source>
      <translation>QGIS의 파이썬({python})에 있는 pip은 {version}입니다. 설치에는 pip 22.2 이상이 필요한데, 패키지 색인에서 pip 자체의 휠을 받아 오지 못했습니다({reason}): {command}</translation>
    </message>
    <message>
      <source>QGIS's Python ({python}) has no pip, and pip's own wheel could not be fetched from the package index ({reason}).</source>
      <translation>QGIS의 파이썬({python})에 pip이 없고, 패키지 색인에서 pip 자체의 휠도 받아 오지 못했습니다({reason}).</translation>
    </message>
    <message>
      <source>Running: {command}</source>
      <translation>실행 중: {command}</translation>
    </message>
    <message>
      <source>Nothing was installed.</source>
      <translation>아무것도 설치하지 않았습니다.</translation>
    </message>
    <message>
      <source>Then run 'Install Python dependencies' again.</source>
      <translation>그런 다음 '파이썬 의존 패키지 설치'를 다시 실행하십시오.</translation>
    </message>
    <message>
      <source>{module}: a wheel from PyPI bundles a C library that QGIS loads itself and would crash QGIS; the platform's package {package} is the safe one.</source>
      <translation>{module}: PyPI의 휠은 QGIS가 직접 불러오는 C 라이브러리를 담고 있어 QGIS를 비정상 종료시킬 수 있습니다. 플랫폼 패키지 {package}가 안전합니다.</translation>
    </message>
    <message>
      <source>shapely: the system GEOS development files are version {system}, but QGIS runs GEOS {qgis}; a shapely built against them would crash QGIS. Install the GEOS development files of QGIS's GEOS.</source>
      <translation>shapely: 시스템의 GEOS 개발 파일은 {system} 버전인데 QGIS는 GEOS {qgis}를 씁니다. 이에 맞춰 빌드한 shapely는 QGIS를 비정상 종료시킬 수 있으니 QGIS가 쓰는 GEOS의 개발 파일을 설치하십시오.</translation>
    </message>
    <message>
      <source>The installed packages do not import; nothing was installed:</source>
      <translation>설치한 패키지를 가져올(import) 수 없어 아무것도 설치하지 않았습니다:</translation>
    </message>
    <message>
      <source>The shapely built here uses GEOS {built}, QGIS uses GEOS {qgis}; it would crash QGIS, so nothing was installed.</source>
      <translation>여기서 빌드한 shapely는 GEOS {built}를, QGIS는 GEOS {qgis}를 씁니다. QGIS를 비정상 종료시킬 수 있으므로 아무것도 설치하지 않았습니다.</translation>
    </message>
    <message>
      <source>pip's own wheel could not be downloaded ({reason}).</source>
      <translation>pip 자체의 휠을 내려받지 못했습니다({reason}).</translation>
    </message>
    <message>
      <source>{module}: a wheel from PyPI bundles a C library that QGIS loads itself and would crash QGIS; install your distribution's package ({package}).</source>
      <translation>{module}: PyPI의 휠은 QGIS가 직접 불러오는 C 라이브러리를 담고 있어 QGIS를 비정상 종료시킬 수 있습니다. 배포판의 패키지({package})를 설치하십시오.</translation>
    </message>
    <message>
      <source>pip wants {name} in two versions ({first}, {second}); install the packages one at a time.</source>
      <translation>pip이 {name}을(를) 두 가지 버전({first}, {second})으로 요구합니다. 패키지를 하나씩 설치하십시오.</translation>
    </message>
    <message>
      <source>pip failed installing {package} (exit code {code}); nothing was installed:</source>
      <translation>pip이 {package} 설치에 실패했습니다(종료 코드 {code}). 아무것도 설치하지 않았습니다:</translation>
    </message>
    <message>
      <source>pip cannot install {module} on this Python ({requirements}):</source>
      <translation>pip이 이 파이썬에 {module}을(를) 설치할 수 없습니다({requirements}):</translation>
    </message>
  </context>
</TS>
