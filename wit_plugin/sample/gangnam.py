"""Real Gangnam-gu names and codes the synthetic city uses: legal dongs, arterial roads, building-use
codes, roof styles and ground classes the renderer draws, and names for apartments, offices and villas."""
from __future__ import annotations

# Real Gangnam-gu legal dongs (TL_SCCO_EMD): code, English and Korean names, the dong's centroid
# as an offset in metres (EPSG:5179) from Suseo station, and the first lot number we hand out.
DONGS = (
    ("11680101", "Yeoksam-dong", "역삼동", -5603, 1410, 600),
    ("11680103", "Gaepo-dong", "개포동", -3488, -797, 1200),
    ("11680104", "Cheongdam-dong", "청담동", -4536, 4103, 1),
    ("11680105", "Samseong-dong", "삼성동", -4042, 2944, 1),
    ("11680106", "Daechi-dong", "대치동", -3411, 1301, 500),
    ("11680107", "Sinsa-dong", "신사동", -6654, 4048, 500),
    ("11680108", "Nonhyeon-dong", "논현동", -6199, 2922, 1),
    ("11680110", "Apgujeong-dong", "압구정동", -6476, 4816, 300),
    ("11680111", "Segok-dong", "세곡동", 219, -2578, 100),
    ("11680112", "Jagok-dong", "자곡동", -151, -1257, 200),
    ("11680113", "Yulhyeon-dong", "율현동", 883, -1866, 50),
    ("11680114", "Irwon-dong", "일원동", -1692, 53, 600),
    ("11680115", "Suseo-dong", "수서동", -468, -189, 700),
    ("11680118", "Dogok-dong", "도곡동", -5014, 133, 400),
)


SUSEO_DONG = 12


SUSEO_STATION_5179 = (964814.8599, 1943225.0080)  # 127.1020°E 37.4876°N on Korea 2000


# Real Gangnam-gu roads (TL_SPRD_MANAGE, 2019) used for the arterial grid, nearest first:
# RN, ENG_RN, RN_CD, ROAD_BT, ROAD_LT, ROA_CLS_SE, WDR_RD_CD, ALWNC_DE, ALWNC_RESN, NTFC_DE, RBP_CN, REP_CN.
ARTERIALS = (
    ("밤고개로", "Bamgogae-ro", "3122003", 30.0, 3592.0, "3", "3", "20090701",
     "율현동의 순수 우리말인 밤고개를 인용하여 제정", "20090710", "수서동 725", "세곡동 151-14"),
    ("광평로", "Gwangpyeong-ro", "3122002", 30.0, 3334.0, "3", "3", "20100419",
     "광평대군의 묘역이 위치하여 묘역의 명칭을 사용하여 제정", "20100420", "일원동 702-11", "수서동 718"),
    ("남부순환로", "Nambusunhwan-ro", "2000003", 41.0, 32620.0, "2", "1", "20090710",
     "서울의 남쪽을 연결하는 도로", "20100315", "강서구 방화동 434-10", "강남구 수서동 329-21"),
    ("자곡로", "Jagok-ro", "3122014", 35.0, 3010.769, "3", "3", "20120607", "자곡동 명칭 인용", "20120615",
     "세곡동 산52-40", "자곡동 45"),
    ("헌릉로", "Heolleung-ro", "3000033", 35.0, 10907.0, "3", "1", "20090701", "헌인릉의 지역적 특성을 부여",
     "20090710", "서초구 양재동 238-1", "성남시 수정구 신흥동 8-4"),
    ("분당수서로", "Bundangsuseo-ro", "3180055", 30.0, 25338.0, "3", "1", "20090710", "분당 수서간 자동차전용도로",
     "20090710", "성남시 분당구 구미동 174", "광진구 자양동 97-5"),
    ("양재대로", "Yangjae-daero", "2000006", 50.0, 19360.0, "2", "1", "20100310", "지역명 사용", "20180308",
     "서울 서초구 중앙로 626", "경기 구리시 강변북로 224"),
    ("삼성로", "Samseong-ro", "3122005", 35.0, 5061.0, "3", "3", "20100419", "삼성동 행정구역명을 인용하여  제정",
     "20100422", "개포동 191", "청담동 48"),
    ("도곡로", "Dogok-ro", "3122012", 40.0, 4700.0, "3", "2", "20100422", "행정구역 명칭 사용", "20100422",
     "서울특별시 강남구 도곡동 943(강남대로)", "서울특별시 송파구 잠실동 294 (백제고분로)"),
    ("봉은사로", "Bongeunsa-ro", "3122004", 35.0, 4200.0, "3", "3", "20100419",
     "강남개발 이전부터 존재하던 주요문화재 봉은사의 명칭을 인용", "20100422", "논현동 200-7", "삼성동 171-4"),
    ("언주로", "Eonju-ro", "3005086", 40.0, 12080.0, "3", "2", "20090701", "옛 지명 인용", "20090710",
     "서울특별시 서초구 내곡동 산12-431(인능산1자연공원)", "서울특별시 강남구 압구정동 480"),
    ("논현로", "Nonhyeon-ro", "3121022", 30.0, 8300.0, "3", "2", "20100520", "행정구역명칭 인용", "20100520",
     "서울특별시 서초구 양재동 402-6(양재대로)", "서울특별시 성동구 옥수동 487(동호대교 북단)"),
    ("테헤란로", "Teheran-ro", "3122010", 50.0, 3898.0, "2", "3", "20100419",
     "테헤란시와 서울시의 자매결연을 기념 상호 도시명을 도로명으로 제정", "20100422", "역삼동 821", "삼성동 171-3"),
    ("강남대로", "Gangnam-daero", "2102001", 50.0, 7820.0, "2", "2", "20090701", "행정구역 명칭 사용", "20090710",
     "서울특별시 서초구 양재동 238-1(염곡사거리)", "서울특별시 용산구 한남동 782(한강대교북단)"),
    ("압구정로", "Apgujeong-ro", "3122007", 30.0, 3041.0, "3", "3", "20100419", "행정구역 명칭 적용", "20100422",
     "압구정동 408", "청담동 119-2"),
    ("도산대로", "Dosan-daero", "2122001", 50.0, 3262.0, "2", "3", "20080901",
     "일제시대 독립운동가인 안창호 선생의 호 도산을 인용, 도산대로변에는 도산의 묘원인 도산공원이 위치함", "20080926",
     "강남구 신사동 501-2", "청담동 130"),
    ("학동로", "Hakdong-ro", "3122011", 40.0, 3755.0, "3", "3", "20100419",
     "본래 학로였으나 1984년 11월 7일 가로명 제정때 학동로로 부여", "20100422", "논현동 50-2", "청담동 134-18"),
    ("일원로", "Irwon-ro", "3122009", 25.0, 1430.0, "3", "3", "20080901",
     "이 노선이 지나는 일원동의 행정구역명을 적용하여 제정", "20101203", "일원동 618-3", "일원동 738"),
    ("개포로", "Gaepo-ro", "3122001", 20.0, 4526.0, "3", "3", "20100419",
     "이 노선이 지나는 개포동의 행정구역명을 적용하여 제정", "20100422", "개포동 1239-18", "일원동 644-11"),
    ("선릉로", "Seolleung-ro", "3122006", 25.0, 6352.0, "3", "3", "20080901",
     "조선 제9대 왕인 성종과 성종의 계비 정현왕후의 능인 선릉에서 유래", "20101203", "개포동 567-22", "압구정동 510"),
    ("역삼로", "Yeoksam-ro", "3122008", 20.0, 3607.0, "3", "3", "20100419", "행정구역 명칭 적용", "20100422",
     "역삼동 831-16", "대치동 1004-3"),
    ("양재천로", "Yangjaecheon-ro", "3121023", 20.0, 4500.0, "3", "2", "20100419", "양재천 명칭 인용", "20100422",
     "서울특별시 서초구 우면동 23-14(경부고속도로 하부)", "서울특별시 강남구 대치동 513(영동대로)"),
)


# Building-use codes (건축물 용도코드, BDTYP_CD).
DETACHED_HOUSE, MULTI_HOUSEHOLD, APARTMENT, ROW_HOUSE, MULTIPLEX = "01001", "01003", "02001", "02002", "02003"


RETAIL, RESTAURANT, PERFORMANCE_HALL, OFFICE = "03001", "04001", "05001", "14201"


SCHOOLS = (("초등학교", "Elementary School", "10101"), ("중학교", "Middle School", "10102"),
           ("고등학교", "High School", "10103"))


# Roof styles, drawn by the orthoimage renderer.
ROOF_CONCRETE, ROOF_GREEN, ROOF_RED_TILE, ROOF_BROWN_TILE, ROOF_BLUE_METAL, ROOF_WHITE, ROOF_DARK = range(7)


PITCHED_ROOFS = (ROOF_RED_TILE, ROOF_BROWN_TILE)


# Ground classes, drawn by the orthoimage renderer (0 is sidewalk / paving, the background).
GROUND_LAWN, GROUND_FOREST, GROUND_BARE, GROUND_PARKING, GROUND_LANE = 1, 2, 3, 4, 5


APT_BRANDS = (("삼익", "Samik"), ("신동아", "Sindonga"), ("한아름", "Hanareum"), ("까치마을", "Kkachimaeul"),
               ("현대", "Hyundai"), ("우성", "Woosung"), ("래미안", "Raemian"), ("푸르지오", "Prugio"),
               ("자이", "Xi"), ("힐스테이트", "Hillstate"), ("롯데캐슬", "Lotte Castle"), ("더샵", "The Sharp"),
               ("아이파크", "I-Park"), ("쌍용", "Ssangyong"), ("한신", "Hanshin"), ("상록수", "Sangroksu"),
               ("목련타운", "Mongnyeon Town"), ("청솔", "Cheongsol"), ("푸른마을", "Pureun Maeul"),
               ("데시앙포레", "Desian Foret"), ("강남힐즈", "Gangnam Hills"), ("샘터마을", "Saemteo Maeul"))


OFFICE_PREFIXES = (("대원", "Daewon"), ("한솔", "Hansol"), ("동아", "Donga"), ("세방", "Sebang"), ("KT", "KT"),
                    ("신한", "Shinhan"), ("삼환", "Samhwan"), ("대림", "Daelim"), ("광림", "Gwangrim"),
                    ("유니온", "Union"), ("에이스", "Ace"), ("SRT", "SRT"), ("현대", "Hyundai"), ("금강", "Geumgang"))


OFFICE_SUFFIXES = (("빌딩", "Bldg."), ("타워", "Tower"), ("프라자", "Plaza"), ("센터", "Center"))


VILLA_NAMES = ("그린빌라", "한양빌라", "세림하이츠", "삼성맨션", "동원빌라", "대림하우스", "우정빌라", "청구빌라",
                "해오름빌", "수정캐슬", "라움하우스", "예림빌")


def dong_stem(index: int) -> tuple[str, str]:
    """Korean and English dong name without the 동/-dong suffix, e.g. ('수서', 'Suseo')."""
    _, eng, kor, *_ = DONGS[index]
    return kor[:-1], eng[: -len("-dong")]
