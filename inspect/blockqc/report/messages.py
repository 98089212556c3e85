"""The report's message catalogue: every label in English and Chinese, from one place."""

from __future__ import annotations

from collections.abc import Callable

LANGUAGES = ("en", "zh")

# key -> (English, Chinese). Keys used by the templates and by the plots.
MESSAGES: dict[str, tuple[str, str]] = {
    # --- page furniture
    "block_report": ("Acceptance report of block {block}", "区域网 {block} 验收报告"),
    "batch_summary": ("Batch summary", "批次汇总"),
    "report_subtitle": (
        "Satellite block adjustment without ground control points",
        "无地面控制点卫星影像区域网平差成果",
    ),
    "generated_by": (
        "Generated {date} by blockqc {version}",
        "由 blockqc {version} 于 {date} 生成",
    ),
    "rendered_from": (
        "Rendered from results.json; rule pack files: {files}",
        "由 results.json 生成；规则包文件：{files}",
    ),
    # --- header
    "block": ("Block", "区域网"),
    "sensor": ("Sensor", "传感器"),
    "rule_pack": ("Rule pack", "规则包"),
    "inspector": ("Inspector", "检查员"),
    "date": ("Date", "日期"),
    "verdict": ("Overall verdict", "总体结论"),
    "delivery": ("Delivery", "成果路径"),
    "contents": ("Contents", "成果内容"),
    "contents_one_scene": (
        "; {n} of the tie points are observed on one scene only: they tie no scenes, and are "
        "counted as delivered",
        "；其中 {n} 个连接点仅在一景影像上有观测：未连接任何影像，按所交数据计入",
    ),
    "contents_text": (
        "{scenes} scenes, {tie_points} tie points ({observations} observations), "
        "{checkpoints} checkpoints",
        "影像 {scenes} 景，连接点 {tie_points} 个（观测 {observations} 个），"
        "检查点 {checkpoints} 个",
    ),
    "not_read": ("Not read", "未读取"),
    "input_warnings": ("Input warnings", "输入警告"),
    # results.json's input_warnings (engine.input_warnings): a scene apart from the block
    "iw_scene_apart": (
        "{where}: scene '{scene}' lies apart from the block: its footprint is {gap} km from the "
        "nearest of the block's other scenes ('{nearest}'), more than {k} times its own size "
        "({size} km): expected the footprints of one block side by side (its coordinates in "
        "error?)",
        "{where}：影像 '{scene}' 远离区块：其范围距区块内最近的其他影像（'{nearest}'）{gap} 千米，"
        "超过其自身尺寸（{size} 千米）的 {k} 倍：同一区块的影像范围应彼此相邻（其坐标有误？）",
    ),
    "iw_scenes_apart": (
        "{where}: the scenes' footprints fall into {groups} groups apart from each other (the "
        "largest {largest} of {n} scenes), each more than {k} scene sizes from the others: "
        "expected the footprints of one block side by side (coordinates in error?)",
        "{where}：影像范围分成 {groups} 组，彼此相距超过影像尺寸的 {k} 倍（最大一组为 {n} 景中的 "
        "{largest} 景）：同一区块的影像范围应彼此相邻（坐标有误？）",
    ),
    # … and a point given two ground points
    "iw_ground_differs": (
        "{where}: point '{point}' is given {column} {value} here and {first} on row {row}: "
        "expected one ground point per point (the producer's), the same on each of its rows; "
        "judged as given (RC-1 with ground: delivered back-projects each row's own ground point)",
        "{where}：点 '{point}' 在此给出 {column} {value}，在第 {row} 行给出 {first}：每个点应只有"
        "一个地面点（生产方的），在其各行上相同；按所给评判（RC-1 取 ground: delivered 时按各行"
        "自己的地面点反投影）",
    ),
    "iw_ground_more": (
        "{where}: {n} more rows give their point another {column} than its first row: expected "
        "one ground point per point (the producer's), the same on each of its rows; judged as "
        "given (RC-1 with ground: delivered back-projects each row's own ground point)",
        "{where}：另有 {n} 行给出的 {column} 与其点的第一行不同：每个点应只有一个地面点（生产方"
        "的），在其各行上相同；按所给评判（RC-1 取 ground: delivered 时按各行自己的地面点反投影）",
    ),
    # … and a document kind of block.yaml close to one of the contract's it does not give
    # … and the scenes inspected without their RPC (contract v1.1)
    "iw_scenes_without_rpc": (
        "{where}: no RPC file for scene(s) {scenes} of the scenes table, which have no tie-point "
        "observations (expected rpc/<scene_id>.<ext> for every scene): inspected without them; "
        "blockqc adjust leaves them out, not adjusted",
        "{where}：影像表中的影像 {scenes} 没有 RPC 文件，也没有连接点观测（每景影像应有 "
        "rpc/<scene_id>.<ext>）：检查时不计这些影像；blockqc adjust 亦不计这些影像，不对其作平差",
    ),
    # … and ground columns a Parquet table stores coarser than float64 (blockqc.precision)
    "iw_stored_type": (
        "{where}: {columns} (the resolution of each at its largest value) stored as {type}, not "
        "float64: the figures of {figures} are no finer than that",
        "{where}：{columns}（各列在其最大值处的分辨率）以 {type} 而非 float64 存储：{figures} 的"
        "数值精度不会优于此分辨率",
    ),
    "iw_stored_type_coarse": (
        "{where}: {columns} (the resolution of each at its largest value) stored as {type}, not "
        "float64: coarser than {share} of the plane norm ({limit} m), the figures of {figures} "
        "may be off by that much; write these columns as float64 (double)",
        "{where}：{columns}（各列在其最大值处的分辨率）以 {type} 而非 float64 存储：粗于平面"
        "限值的 {share}（{limit} m），{figures} 的数值可能因此偏差同样大小；请以 float64"
        "（双精度）写出这些列",
    ),
    "iw_document_kind": (
        "{where}: not a document kind of the contract; did you mean '{kind}'?",
        "{where}：不是合同规定的文档类型；是否应为 '{kind}'？",
    ),
    "not_read_text": (
        "{columns}: no rule of the pack reads these columns (the pack reads only the columns "
        "its rules use); their checks, and those of keys over them, were not made",
        "{columns}：规则包中没有规则读取这些列（规则包只读取其规则所用的列），未对其及以其为键的"
        "唯一性进行检查",
    ),
    "complete": ("Complete", "检查完成"),
    "awaiting": ("Awaiting the inspector", "待检查员判定"),
    "not_given": ("not given", "未填写"),
    "none": ("none", "无"),
    "yes": ("yes", "是"),
    "no": ("no", "否"),
    "signature": ("Signature", "签字"),
    "inspector_sign": ("Inspector", "检查员"),
    "reviewer_sign": ("Reviewer", "审核人"),
    "verdict_pass": ("PASS", "合格"),
    "verdict_fail": ("FAIL", "不合格"),
    "verdict_error": ("ERROR", "错误"),
    "counts_line": (
        "{pass_} pass, {fail} fail, {warn} warn, {waived} waived, {manual} manual, "
        "{na} not applicable, {error} error",
        "合格 {pass_}，不合格 {fail}，警告 {warn}，豁免 {waived}，待人工 {manual}，"
        "不适用 {na}，错误 {error}",
    ),
    # --- statuses
    "status_pass": ("pass", "合格"),
    "status_fail": ("fail", "不合格"),
    "status_warn": ("warn", "警告"),
    "status_waived": ("waived", "豁免"),
    "status_manual": ("manual", "待人工判定"),
    "status_not_applicable": ("n/a", "不适用"),
    "status_error": ("error", "错误"),
    # --- sections
    "sec_contents": ("Inspection contents", "检查内容"),
    "sec_contents_intro": (
        "Each inspection content of the quality-inspection method (DOMAIN §2), "
        "grouped by quality element and item; its status is the worst of "
        "the rules that decide it.",
        "按质量元素和检查项列出质量检查方法的各项检查内容（DOMAIN §2）；"
        "其状态取决定它的各条规则中最差者。",
    ),
    "sec_general": ("General inspection", "概查"),
    "sec_general_intro": (
        "Every delivered block, automatically: tie points, relative orientation, "
        "process data and documents.",
        "对每个提交的区域网自动检查：连接点、相对定向、过程数据与文档资料。",
    ),
    "sec_process_data": ("Where the process data came from", "过程数据来源"),
    "sec_process_data_intro": (
        "What the delivery gave and what blockqc computed itself from the delivered geometry "
        "(§RC-1, §RC-2); the rules above judge these.",
        "成果所给的数据，以及 blockqc 依据所交几何模型自行计算的数据（§RC-1、§RC-2）；"
        "上列规则据此判定。",
    ),
    "pd_geometry": ("Geometry used", "所用几何模型"),
    "pd_residuals": ("Tie-point residuals", "连接点残差"),
    "pd_residual_convention": ("Residuals' convention", "残差约定"),
    "pd_points": ("Tie points", "连接点数"),
    "pd_single_ray": ("seen on one scene only (not intersected)", "仅在一景影像上（未交会）"),
    "pd_not_intersected": ("whose rays do not intersect", "光线无法交会"),
    "pd_height_undetermined": (
        "whose rays fix no height (nearly parallel)",
        "光线近于平行、无法确定高程",
    ),
    "pd_iterations": ("Intersection iterations", "前方交会迭代次数"),
    "pd_observations_without_residual": (
        "Observations without a computed residual",
        "未能计算残差的观测",
    ),
    "pd_observations_single_ray": (
        "Observations of single-ray points, left out of the tie-point rules",
        "单像点观测（不参与连接点规则）",
    ),
    "pd_overlaps": ("Adjacent-image discrepancies", "相邻影像接边差"),
    "pd_n_overlaps": ("Adjacent-image discrepancies derived", "推算的相邻影像接边差个数"),
    "pd_inspector_checkpoints": ("Inspector's checkpoints", "检查员检查点"),
    "pd_rows": ("{n} rows", "{n} 行"),
    "sec_detailed": ("Detailed inspection: checkpoint accuracy", "详查：检查点精度"),
    "sec_detailed_intro": (
        "Checkpoint statistics per component and method, in the layout of the "
        "published statistical tables (§CP-3..8).",
        "按分量和检查方法统计检查点精度，格式同公开的精度统计表（§CP-3..8）。",
    ),
    "not_sampled": (
        "This block was not sampled for detailed inspection (no checkpoints).",
        "该区域网未被抽取详查（无检查点）。",
    ),
    "sec_manual": ("Manual items", "人机交互检查项"),
    "sec_manual_intro": (
        "Items decided by the inspector at the screen.",
        "由检查员人机交互判定的检查项。",
    ),
    "sec_waivers": ("Waivers and exemptions", "豁免与例外"),
    "sec_waivers_intro": (
        "Units waived by the inspector with the reason given, and units exempt "
        "by rule (e.g. scenes that are mostly water).",
        "检查员豁免的单元及其理由，以及按规则免检的单元（如大部分为水域的影像）。",
    ),
    "sec_failures": ("Failures and their evidence", "不合格项及其依据"),
    "sec_failures_intro": (
        "Every result that fails, is in error, warns or was waived, with the offending scenes, "
        "pairs, points and values, the worst first.",
        "所有不合格、出错、警告或经豁免的结果，列出问题影像、像对、点位及其数值，最差者在前。",
    ),
    "no_failures": ("No failures.", "无不合格项。"),
    "sec_summary_blocks": ("Blocks", "区域网"),
    "sec_summary_rules": ("Results per rule", "各规则结果统计"),
    "sec_summary_sampled": ("Sampled blocks: detailed inspection", "抽样区域网：详查结果"),
    "sec_unreadable": ("Unreadable deliveries", "无法读取的成果"),
    "filter": ("Filter", "筛选"),
    "filter_placeholder": ("block, rule …", "区域网、规则…"),
    "all_verdicts": ("all verdicts", "全部结论"),
    "shown": ("shown", "显示"),
    "sort_hint": ("Click a column heading to sort.", "点击列标题排序。"),
    "report_links": ("Reports", "报告"),
    "batch_counts": (
        "{blocks} blocks: {pass_} pass, {fail} fail, {unreadable} unreadable",
        "区域网 {blocks} 个：合格 {pass_}，不合格 {fail}，无法读取 {unreadable}",
    ),
    "batch_counts_error": (
        "{blocks} blocks: {pass_} pass, {fail} fail (of which {error} ERROR: a rule could not be "
        "judged), {unreadable} unreadable",
        "区域网 {blocks} 个：合格 {pass_}，不合格 {fail}（其中“错误”{error} 个：有规则无法判定），"
        "无法读取 {unreadable}",
    ),
    "blocks": ("Blocks", "区域网"),
    "sampled": ("Sampled", "抽样"),
    "failed_rules": ("Failed rules", "不合格规则"),
    "warned_rules": ("Warnings", "警告规则"),
    "path": ("Path", "路径"),
    "problems": ("Problems", "问题"),
    # --- table headings
    "content": ("Inspection content", "检查内容"),
    "rules": ("Rules", "规则"),
    "rule": ("Rule", "规则"),
    "title": ("Title", "名称"),
    "group": ("Group", "分组"),
    "status": ("Status", "状态"),
    "value": ("Value", "实测值"),
    "threshold": ("Threshold", "限值"),
    "unit": ("Unit", "单位"),
    "clause": ("Clause", "条款"),
    "method_col": ("Method", "检查方法"),
    "note": ("Note", "说明"),
    "reason": ("Reason", "理由"),
    "units": ("Units", "单元"),
    "kind": ("Kind", "类别"),
    "evidence": ("Evidence", "依据"),
    "evidence_rows": (
        "{shown} row(s) of {total}, the worst first",
        "共 {total} 行，显示 {shown} 行，最差者在前",
    ),
    "not_checked": ("not checked by this pack", "本规则包未检查"),
    "component": ("Component", "分量"),
    "n_total": ("Checkpoints", "检查点数"),
    "n_used": ("n used", "参与统计点数"),
    "medium_error": ("Medium error (m)", "中误差（m）"),
    "max_error": ("Maximum error (m)", "最大误差（m）"),
    "n_gross": ("Gross errors", "粗差个数"),
    "gross_rate": ("Gross-error rate", "粗差率"),
    "statistic": ("Statistic", "统计量"),
    "used_mean": ("Mean used", "以平均误差代替"),
    "norm": ("Norm (m)", "规定中误差（m）"),
    "bound": ("Tolerance (m)", "限差（m）"),
    "agreement": ("Agreement of methods", "方法间一致性"),
    "agree": ("agree", "一致"),
    "disagree": ("differ", "不一致"),
    "spread": ("Spread (m)", "差值（m）"),
    "used_mean_note": (
        "Too few checkpoints for the medium error: the mean error replaces it (§CP-7).",
        "检查点数不足：以平均误差代替中误差（§CP-7）。",
    ),
    "used_mean_note_n": (
        "Fewer than {n} checkpoints: the mean error replaces the medium error (§CP-7).",
        "检查点少于 {n} 个：以平均误差代替中误差（§CP-7）。",
    ),
    "tp_rms_beside": ("RMS (medium error) {value} {unit}", "中误差（均方根）{value} {unit}"),
    "tp_median_beside": ("Median {value} {unit}", "中位数 {value} {unit}"),
    "checkpoint_list": ("Checkpoints", "检查点明细"),
    "point_id": ("Point", "点号"),
    "reference_id": ("Reference", "参考数据"),
    "error": ("Error (m)", "误差（m）"),
    "gross": ("Gross", "粗差"),
    "scene_id": ("Scene", "影像"),
    "band": ("Band", "波段"),
    "acquired": ("Acquired", "获取日期"),
    "n_points": ("Tie points", "连接点数"),
    "coverage": ("Coverage", "格网覆盖率"),
    "clark_evans": ("Clark–Evans R", "Clark–Evans 系数 R"),
    "exempt": ("Exempt", "免检"),
    "decided_by": ("Decided by", "判定人"),
    "verdict_given": ("Verdict", "判定结论"),
    # --- evidence columns
    "col_scene_a": ("Scene A", "影像 A"),
    "col_scene_b": ("Scene B", "影像 B"),
    "col_pan_scene_id": ("PAN scene", "全色影像"),
    "col_ms_scene_id": ("MS scene", "多光谱影像"),
    "col_neighbour_block": ("Adjacent block", "相邻区域网"),
    "col_value_m": ("Discrepancy (m)", "差值（m）"),
    "col_figure": ("Figure", "数值项"),
    "col_reported": ("Reported", "报告值"),
    "col_recomputed": ("Recomputed", "复算值"),
    "col_difference": ("Difference", "差"),
    "col_problem": ("Problem", "问题"),
    "col_dx_m": ("dx (m)", "dx（m）"),
    "col_dy_m": ("dy (m)", "dy（m）"),
    "col_dz_m": ("dz (m)", "dz（m）"),
    "col_error_m": ("Error (m)", "误差（m）"),
    "col_conforms": ("Conforms", "符合"),
    "col_kind": ("Document", "文档"),
    "col_present": ("Present", "存在"),
    "col_readable": ("Readable", "可读"),
    "col_size_bytes": ("Size (bytes)", "大小（字节）"),
    "col_agrees": ("Agrees", "一致"),
    "col_method": ("Method", "检查方法"),
    "col_water_fraction": ("Water share", "水域比例"),
    "col_cells_covered": ("Cells covered", "有点格网数"),
    "col_cells_expected": ("Land cells", "陆地格网数"),
    "col_n_points": ("Points", "点数"),
    "col_abs_error_m": ("|Error| (m)", "误差绝对值（m）"),
    "col_bound_m": ("Bound (m)", "限差（m）"),
    "whole_rule": ("the whole rule", "整条规则"),
    "waiver_ignored": ("Waiver ignored", "豁免无效"),
    "truncated": ("{n} more not listed in results.json", "另有 {n} 行未列入 results.json"),
    "residual_map_not_kept": (
        "The map of tie-point residuals is drawn for blocks of at most {most} scenes; this "
        "block has {n}.",
        "连接点残差矢量图仅对不超过 {most} 景影像的区域网绘制；本区域网有 {n} 景。",
    ),
    "overlap_map_not_kept": (
        "The map of adjacent-image discrepancies is not drawn: results.json does not keep the "
        "{n} discrepancy points of this block (the failing ones are listed under the failures).",
        "未绘制相邻影像接边差图：results.json 未保存本区域网的 {n} 个接边点"
        "（不合格者列于不合格项中）。",
    ),
    "maps_capped": (
        "The first {n} of {total} failing scenes are drawn.",
        "仅绘出 {total} 景不合格影像中的前 {n} 景。",
    ),
    # --- units of the stock rules
    "unit_points": ("points", "个"),
    "unit_share of cells": ("share of cells", "格网覆盖率"),
    "unit_px": ("px", "像素"),
    # --- results that decide no inspection content of the pack
    "qe_other": ("Other rules of the pack", "规则包中的其他规则"),
    "it_other": ("Other", "其他"),
    # --- methods and components
    "method_high_precision": ("High-precision data", "高精度数据法"),
    "method_same_accuracy": ("Same-accuracy data", "同精度数据法"),
    "method_recalculation": ("Recalculation with other software", "其他软件重新计算法"),
    "no_method_cps": ("no {method} checkpoints", "没有{method}检查点"),
    "no_methods_cps": (
        "no checkpoints of the methods {methods}",
        "没有以下检查方法的检查点：{methods}",
    ),
    "component_plane": ("Plane", "平面"),
    "component_height": ("Height", "高程"),
    "stat_M1": ("M1 = √(ΣΔ²/n)", "M1 = √(ΣΔ²/n)"),
    "stat_M2": ("M2 = √(ΣΔ²/2n)", "M2 = √(ΣΔ²/2n)"),
    # the mean error in place of M1 or M2 (§CP-7): divided by √2 as M2 is
    "stat_mean_M1": ("mean error = Σ|Δ|/n", "平均误差 = Σ|Δ|/n"),
    "stat_mean_M2": ("mean error = Σ|Δ|/(√2·n)", "平均误差 = Σ|Δ|/(√2·n)"),
    "stat_mean": ("mean error", "平均误差"),
    # --- plots
    "fig_cp_errors": ("Checkpoint errors per point, {component}", "检查点误差分布（{component}）"),
    "fig_cp_vectors": ("Plane error vectors of the checkpoints", "检查点平面误差矢量图"),
    "fig_cp_scatter": ("Plane errors of the checkpoints (dx, dy)", "检查点平面误差（dx, dy）"),
    "fig_tp_hist": ("Tie-point residuals", "连接点残差直方图"),
    "fig_tp_counts": ("Tie points per scene", "每景影像连接点数量"),
    "fig_footprints": ("Scene footprints by status", "影像范围及检查状态"),
    "fig_overview": ("Blocks of the batch by verdict", "批次各区域网范围及检查结论"),
    "fig_overview_where": ("Blocks of the batch by verdict: groups", "批次各区域网分组位置"),
    "fig_overview_group": (
        "Group {group} by verdict: {n} of the batch's blocks",
        "{group} 组区域网范围及检查结论：共 {n} 个区域网",
    ),
    "lg_overview_group": ("group (own map)", "分组（单独成图）"),
    "summary_tables": ("For spreadsheets", "表格文件"),
    "sec_scene_maps": (
        "Tie-point distribution of the scenes failing a tie-point count or distribution rule",
        "连接点数量或分布不合格影像的连接点分布",
    ),
    "fig_scene_points": ("Tie-point distribution of scene {scene}", "影像 {scene} 的连接点分布"),
    "ax_error_m": ("error (m)", "误差（m）"),
    "ax_residual_px": ("residual √(v_l² + v_s²) (px)", "残差 √(v_l² + v_s²)（像素）"),
    "ax_observations": ("observations", "观测数"),
    "ax_tie_points": ("tie points", "连接点数"),
    "ax_scene": ("scene", "影像"),
    "ax_easting": ("easting (m)", "东坐标（m）"),
    "ax_northing": ("northing (m)", "北坐标（m）"),
    "ax_dx": ("dx (m)", "dx（m）"),
    "ax_dy": ("dy (m)", "dy（m）"),
    "ax_lon": ("longitude (°)", "经度（°）"),
    "ax_lat": ("latitude (°)", "纬度（°）"),
    "ax_sample": ("sample (px)", "列（像素）"),
    "ax_line": ("line (px)", "行（像素）"),
    "lg_norm": ("norm ±m", "规定中误差 ±m"),
    "lg_norm_plane": ("norm m", "规定中误差 m"),
    "lg_tolerance": ("tolerance", "限差"),
    "lg_gross": ("gross error", "粗差"),
    "lg_minimum": ("minimum {n}", "最少 {n} 个"),
    "lg_exempt": ("exempt", "免检"),
    "lg_vector_scale": ("arrow of {m} m", "箭头长 {m} m"),
    "no_points_kept": (
        "The points of this scene are not in results.json.",
        "results.json 中没有该影像的连接点。",
    ),
    "scene_points_caption": (
        "{n} points shown; {k}×{k} grid, land cells must each hold points (TP-5).",
        "显示 {n} 个点；{k}×{k} 格网，每个陆地格网须有连接点（TP-5）。",
    ),
    "vector_no_positions": (
        "The checkpoints' positions are not in results.json: the plane "
        "errors are drawn from a common origin.",
        "results.json 中没有检查点坐标：平面误差从同一原点绘出。",
    ),
}


# --- quality evaluation and acceptance (§QE)
MESSAGES.update(
    {
        "val_ellipsoidal": ("ellipsoidal", "椭球高"),
        "fig_residual_map": (
            "Tie-point residuals: mean vector per scene and cell of a 4×4 grid\n"
            "(longest {px} px; direction on the ground)",
            "连接点残差：各影像 4×4 格网内平均残差矢量\n（最长 {px} 像素；地面方向）",
        ),
        "fig_overlap_map": (
            "Adjacent-image discrepancies per scene pair\n"
            "mean vector (longest {m} m), largest discrepancy in m{red}",
            "相邻影像各像对接边差\n平均差值矢量（最长 {m} m），旁注最大接边差（m）{red}",
        ),
        "fig_overlap_map_some": (
            "Adjacent-image discrepancies per scene pair\n"
            "mean vector (longest {m} m){red}\n"
            "largest discrepancy in m of {failing} and of the {others} largest others",
            "相邻影像各像对接边差\n平均差值矢量（最长 {m} m）{red}\n"
            "旁注{failing}及其余最大接边差最大的 {others} 个像对的最大接边差（m）",
        ),
        "overlap_red": (
            "; red: the largest fails {rule} ({bound})",
            "；红色：最大接边差不满足 {rule}（{bound}）",
        ),
        "overlap_labels_none": ("no failing pair", "无超限像对"),
        "overlap_labels_failing": ("the {n} failing pairs", "全部 {n} 个超限像对"),
        "overlap_labels_worst": (
            "the {n} worst of the {of} failing pairs",
            "{of} 个超限像对中最大的 {n} 个",
        ),
        "col_x_m": ("Easting x (m)", "东坐标 x（m）"),
        "col_y_m": ("Northing y (m)", "北坐标 y（m）"),
        "col_z_m": ("Height z (m)", "高程 z（m）"),
        "col_line": ("Line (px)", "行（像素）"),
        "col_sample": ("Sample (px)", "列（像素）"),
        "col_v_line": ("v line (px)", "行残差（像素）"),
        "col_v_sample": ("v sample (px)", "列残差（像素）"),
        "col_v_line_computed": ("v line computed (px)", "复算行残差（像素）"),
        "col_v_sample_computed": ("v sample computed (px)", "复算列残差（像素）"),
        "col_difference_px": ("Difference (px)", "差值（像素）"),
        "col_n_rays": ("Rays", "光线数"),
        "col_intersected": ("Intersected", "可交会"),
        "col_error_px": ("Error (px)", "误差（像素）"),
        "agreement_rule": (
            "Criterion: the methods agree when their medium errors are on the same side of the "
            "norm (all within it, or all beyond it).",
            "判据：各方法的中误差均不超过或均超过规定中误差时，视为一致。",
        ),
        "axis_mean": ("Mean (bias)", "平均值（系统偏差）"),
        "axis_std": ("Standard deviation", "标准差"),
        "axis_rms": ("RMS", "均方根"),
        "failed_criterion": ("Criterion failed", "不合格的指标"),
        "val_WGS84": ("WGS84", "WGS-84"),
        "sec_evaluation": ("Quality evaluation", "质量评价"),
        "sec_evaluation_intro": (
            "Scores after {standard}: mathematical accuracy against its norm, other items by "
            "deduction for their errors of classes B, C and D, rolled up by the pack's weights.",
            "依据 {standard} 评分：数学精度按规定中误差计分，其余质量子元素按 B、C、D 类错漏扣分，"
            "按规则包权重汇总。",
        ),
        "score": ("Score", "得分"),
        "grade": ("Grade", "质量等级"),
        "score_grade": ("Quality score and grade", "质量得分与等级"),
        "weight": ("Weight", "权"),
        "errors_by_class": ("Errors by class", "错漏统计"),
        "error_class": ("Class", "错漏类别"),
        "deduction": ("Deduction", "扣分"),
        "accuracy_scores": ("Accuracy m/m0 → score", "精度 m/m0 → 得分"),
        "element_item": ("Quality element / item", "质量元素 / 子元素"),
        "not_inspected": ("not inspected", "未检查"),
        "only_weight_0": ("only items of weight 0 inspected", "仅检查了权为 0 的子元素"),
        "err_beyond_norm": ("beyond the norm", "超过规定中误差"),
        "err_fails": ("fails its threshold", "超出限值"),
        "err_beyond_norm_p": ("(beyond the norm)", "（超过规定中误差）"),
        "err_fails_p": ("(fails its threshold)", "（超出限值）"),
        "a_class_error": ("A-class error", "A 类错漏"),
        "awaiting_on": ("awaiting the inspector's verdict on", "等待检查员判定："),
        "qe_not_judged": ("rule {rule} could not be judged", "规则 {rule} 无法判定"),
        "qe_not_scored": ("{rule} not scored: {why}", "{rule} 未计分：{why}"),
        "qe_norm_no_gsd": (
            "block.yaml gives no gsd_m.{band}, which its score.norm ({norm}) needs: add the "
            "{upper} GSD in metres to gsd_m",
            "block.yaml 未给出 gsd_m.{band}，而其 score.norm（{norm}）需要它："
            "请在 gsd_m 中给出以米为单位的 {upper} 地面采样距离",
        ),
        "qe_norm_problem": (
            "score.norm ({norm}): {problem}",
            "score.norm（{norm}）无法计算：{problem}",
        ),
        "rules_failed": (
            "rules failed: {rules}",
            "未通过的规则：{rules}",
        ),
        "element_below": (
            "{name} scores {score} (below {below})",
            "{name}得分 {score}（低于 {below} 分）",
        ),
        "evaluation_fails": ("The block fails", "单位成果不合格"),
        "evaluation_incomplete": ("The evaluation is not final", "评价尚不完整"),
        "grade_excellent": ("Excellent", "优"),
        "grade_good": ("Good", "良"),
        "grade_pass": ("Pass", "合格"),
        "grade_fail": ("Fail", "不合格"),
        "decision_pass": ("Accepted (pass)", "批成果合格"),
        "decision_fail": ("Rejected (fail)", "批成果不合格"),
        "decision_incomplete": ("Not decided: the sample is incomplete", "未判定：样本检查不完整"),
        "sec_decision": ("Batch decision", "批成果质量判定"),
        "decision": ("Decision", "判定结论"),
        "sample": ("Sample", "样本"),
        "sample_by_plan": ("drawn by the sampling plan", "按抽样方案抽取"),
        "sample_by_cps": (
            "the blocks that carry checkpoints (no sampling plan given)",
            "带检查点的区域网（未给出抽样方案）",
        ),
        "mean_score": ("Mean score of the sample", "样本平均得分"),
        "sample_grade": ("Grade of the sample", "样本质量等级"),
        "batch_grade": ("Batch grade", "批成果质量等级"),
        "shares": (
            "{better} % good or better, {top} % excellent",
            "良级及以上 {better}%，优级 {top}%",
        ),
        "failing_sampled": ("Sampled blocks that fail", "不合格的样本单位"),
        "corrected_sampled": (
            "Sampled blocks with rules failed that do not fail the sample",
            "有规则未通过但不致样本不合格的样本单位",
        ),
        "returned": (
            "Blocks failing the general inspection, returned for correction",
            "概查不合格、退回修改的区域网",
        ),
        "incomplete_blocks": ("Sampled blocks not fully evaluated", "评价不完整的样本单位"),
        "unread_sampled": ("Sampled blocks that could not be read", "无法读取的样本单位"),
        "unread_not_sampled": (
            "Blocks not sampled that could not be read (returned for correction)",
            "无法读取的非样本区域网（退回修改）",
        ),
        "unread_maybe_sampled": (
            "Blocks that could not be read (the plan's sampled {blocks}, not among the blocks "
            "read, may be one of them)",
            "无法读取的区域网（抽样方案的样本单位 {blocks} 不在已读取的区域网中，可能为其中之一）",
        ),
        "unread_no_plan": (
            "Blocks that could not be read: without a sampling plan, whether they carry "
            "checkpoints, so belong to the sample, is not known",
            "无法读取的区域网：未给出抽样方案，无法确定其是否带检查点、是否属于样本",
        ),
        "could_not_be_read": (
            "could not be read (see summary.json)",
            "无法读取（见 summary.json）",
        ),
        "reasons": ("Reasons", "原因"),
        "failed_items": ("Failed items", "不合格项"),
        "failed_items_none": ("No item failed.", "无不合格项。"),
        "filed_title": ("Inspection and acceptance report", "检查验收报告"),
        "report_number": ("Report number", "报告编号"),
        "project": ("Project", "项目名称"),
        "producer": ("Producer", "生产单位"),
        "inspection_unit": ("Inspected by", "检查单位"),
        "sec_basis": ("Inspection basis", "检查依据"),
        "sec_sampling": ("Sampling", "抽样情况"),
        "sampling_text": (
            "{n} of {units} blocks drawn by {method} sampling (seed {seed}).",
            "采用{method}从 {units} 个区域网中抽取 {n} 个（随机种子 {seed}）。",
        ),
        "sampling_plan": ("Sampling plan", "抽样方案"),
        "plan_note_units": (
            "Units of the plan not among the {inspected} deliveries inspected ({n} of its {plan}; "
            "withdrawn after sampling?), none of them sampled, so the sample stands: {blocks}.",
            "抽样方案的 {plan} 个单位中有 {n} 个不在所检的 {inspected} 个成果中（抽样后撤回？），"
            "均未被抽中，样本不变：{blocks}。",
        ),
        "plan_note_batch": (
            "The plan was drawn from batch '{plan}'; the batch inspected is '{inspected}'.",
            "抽样方案抽自批“{plan}”，所检批为“{inspected}”。",
        ),
        "plan_note_sample_size": (
            "A lot of the plan samples {plan} of its units where the pack's table asks "
            "{inspected} (§QE-1): the batch is judged on the smaller sample.",
            "抽样方案的一个批次抽取 {plan} 个单位，规则包的抽样表要求 {inspected} 个（§QE-1）："
            "按较小的样本评定。",
        ),
        "plan_note_rule_pack": (
            "The plan was drawn with rule pack {plan}; the batch is inspected with {inspected}.",
            "抽样方案按规则包 {plan} 抽取，本次检查使用 {inspected}。",
        ),
        "plan_note_seed": (
            "The plan's seed {plan} draws {inspected} by the pack's table (§QE-1); the plan "
            "samples {blocks} in their place (edited by hand, or drawn with another table): the "
            "batch is judged on the plan's sample.",
            "按规则包的抽样表（§QE-1），抽样方案的随机种子 {plan} 抽中 {inspected}；方案却抽取了 "
            "{blocks}（手工修改，或按其他抽样表抽取）：按方案的样本评定。",
        ),
        "plan_note_standard": (
            "The plan was drawn under {plan}; the batch is judged under {inspected}.",
            "抽样方案依据 {plan} 抽取，本批依据 {inspected} 评定。",
        ),
        "strata_by": ("Strata by block.yaml key '{name}'.", "按 block.yaml 的“{name}”分层。"),
        "sampling_none": (
            "No sampling plan was given: the sample is the blocks with checkpoints ({sample}).",
            "未给出抽样方案：样本为带检查点的区域网（{sample}）。",
        ),
        "sample_below_table": (
            "The pack's table (§QE-1) asks a sample of {wanted} of a batch of {units} "
            "deliveries; {n} carry checkpoints: the batch is judged on the smaller sample.",
            "规则包的抽样表（§QE-1）要求从 {units} 个成果中抽取 {wanted} 个；带检查点的仅 {n} 个："
            "按较小的样本评定。",
        ),
        "sampling_table": (
            "Sample size by batch size (the pack's table)",
            "批量与样本量（规则包中的表）",
        ),
        "sampling_method_simple_random": ("simple random", "简单随机抽样"),
        "sampling_method_stratified_proportional_random": (
            "stratified proportional random",
            "分层按比例随机抽样",
        ),
        "lot": ("Lot", "批"),
        "lot_size": ("Batch size", "批量"),
        "sample_size": ("Sample size", "样本量"),
        "census": ("Every unit", "全数检查"),
        "stratum": ("Stratum", "层"),
        "stratum_size": ("Units", "单位数"),
        "sampled_blocks": ("Sampled blocks", "样本区域网"),
        "sec_methods": ("Inspection contents and methods", "检查内容与方法"),
        "element": ("Quality element", "质量元素"),
        "item": ("Quality item", "质量子元素"),
        "sec_problems": ("Main quality problems and their handling", "主要质量问题及处理情况"),
        "handling": ("Handling", "处理情况"),
        "handling_default": (
            "Returned to the producer for correction; re-inspected after correction.",
            "退回生产单位修改，修改后重新检查。",
        ),
        "no_problems": ("No quality problem was found.", "未发现质量问题。"),
        "sec_statistics": ("Quality statistics and evaluation", "质量统计与评价"),
        "grade_distribution": ("Grades", "等级分布"),
        "sec_conclusion": ("Conclusion", "检验结论"),
        "prepared": ("Prepared by", "编写"),
        "reviewed": ("Reviewed by", "审核"),
        "approved": ("Approved by", "批准"),
        "sec_annexes": ("Annexes", "附件"),
    }
)


# --- evidence columns named after the metrics' statistics (their units come from the metric's
# Scope declarations: blockqc.report.format.Formatter.evidence_column)
MESSAGES.update(
    {
        "col_n": ("Count", "个数"),
        "count_observations": ("Observations", "观测数"),
        "count_points": ("Points", "点数"),
        "count_documents": ("Documents", "文档数"),
        "count_rows": ("Rows", "行数"),
        "col_median": ("Median", "中位数"),
        "col_rms": ("RMS", "均方根"),
        "col_mean": ("Mean", "平均值"),
        "col_max": ("Maximum", "最大值"),
        "col_rms_m": ("RMS", "均方根"),
        "col_max_m": ("Maximum", "最大值"),
        "col_mean_m": ("Mean", "平均值"),
        "col_n_in_interval": ("Observations in the interval", "区间内观测数"),
        "col_share_in_interval": ("Share in the interval", "区间内比例"),
        "col_required": ("Required", "必需"),
        "col_ok": ("Conforms", "符合"),
        "col_path": ("File", "文件"),
        "col_band": ("Band", "波段"),
        "col_scene_id": ("Scene", "影像"),
        "col_point_id": ("Point", "点号"),
        "col_epsg": ("EPSG stated", "声明的 EPSG"),
        "col_zone": ("Zone stated", "声明的投影带"),
        "col_expected_epsg": ("EPSG expected from the footprints", "按影像范围应采用的 EPSG"),
        "col_expected_zone": ("Zone expected from the footprints", "按影像范围应采用的投影带"),
        "col_projection_ok": ("Projection conforms", "投影符合"),
        "col_norm_m": ("Norm (m)", "规定中误差（m）"),
        "col_n_units": ("Units", "单元数"),
        "col_n_offending": ("Offending units", "超限单元数"),
        "col_geodetic_datum": ("Geodetic datum", "大地基准"),
        "col_height_datum": ("Height datum", "高程基准"),
        "col_projection": ("Projection", "投影"),
        "unit_m": ("m", "m"),
        "unit_%": ("%", "%"),
        "unit_degrees": ("°", "°"),
        "val_pan": ("PAN", "全色"),
        "val_ms": ("MS", "多光谱"),
        "val_conditional_pass": ("conditional pass", "有条件通过"),
        "val_rework": ("rework", "返工"),
        "condition": ("Condition", "条件"),
        # fixed phrases of results.json (English there), translated when the page is rendered
        "ph_awaiting": ("awaiting the inspector's verdict", "等待检查员判定"),
        "ph_below_grades": ("score below the lowest grade", "得分低于最低质量等级"),
        "qe_below_grades": (
            "score below the lowest grade: {score} < {min} ({grade})",
            "得分低于最低质量等级：{score} < {min}（{grade}）",
        ),
        # why a reported figure is not recomputed (§DOC-2, metrics.reported)
        "ph_not_recomputed": ("cannot be recomputed: ", "无法复算："),
        "ph_no_recomputation": (
            "no recomputation is defined for this figure",
            "该数值未定义复算方法",
        ),
        "ph_nothing_to_recompute": ("nothing to recompute it from", "无可用于复算的数据"),
        # the problems of a document (§DOC-1, metrics.documents.check_document)
        "doc_not_declared": (
            "not declared in block.yaml documents",
            "未在 block.yaml 的 documents 中列出",
        ),
        "doc_loop": (
            "{path}: a symbolic link that leads back to itself",
            "{path}：指向自身的符号链接",
        ),
        "doc_outside": ("{path} points outside the delivery", "{path} 指向成果之外"),
        "doc_folder": ("{path} is a folder, not a document file", "{path} 是文件夹，不是文档文件"),
        "doc_dangling": (
            "{path} is a symbolic link to a file that does not exist",
            "{path} 是指向不存在文件的符号链接",
        ),
        "doc_not_regular": (
            "{path} is not a regular file (a pipe, socket or device)",
            "{path} 不是普通文件（而是管道、套接字或设备）",
        ),
        "doc_missing_case": (
            "{path} does not exist ({found} is there: file names are matched exactly, in their "
            "case)",
            "{path} 不存在（成果中有 {found}：文件名须完全一致，区分大小写）",
        ),
        "doc_missing_link": (
            "{path} does not exist (a symbolic link to a file that does not exist)",
            "{path} 不存在（是指向不存在文件的符号链接）",
        ),
        "doc_missing": ("{path} does not exist", "{path} 不存在"),
        "doc_empty": ("{path} is empty", "{path} 是空文件"),
        "doc_unreadable": ("{path} cannot be read: {why}", "{path} 无法读取：{why}"),
        "doc_invalid": ("{path} is not a valid {kind} file", "{path} 不是有效的 {kind} 文件"),
        "doc_not_utf8": ("{path} is not UTF-8 text", "{path} 不是 UTF-8 文本"),
        "ph_no_geometry": (
            "no geometry in the delivery (rpc/ with adjustment.csv, or rpc_adjusted/)",
            "成果中没有几何模型（rpc/ 及 adjustment.csv，或 rpc_adjusted/）",
        ),
        "ph_mostly_sea": (" (mostly sea)", "（大部分为水域）"),
        "ph_nothing_measured": ("nothing measured for this group", "该组无测量数据"),
        "ph_no_dz_column": (
            "no dz_m column, so no height discrepancies are given",
            "无 dz_m 列，未给出高程较差",
        ),
        "ph_dz_empty": (
            "dz_m empty in every row, so no height discrepancies are given",
            "dz_m 列全部为空，未给出高程较差",
        ),
        # MB-3's note (spatial_ref.py), shown in the page's language (Formatter.sentence)
        "mb_straddles": (
            "the block straddles {edges}; {code} is one of the neighbours allowed",
            "区域网跨越{edges}；{code} 为允许的相邻投影带之一",
        ),
        "mb_edge_both": (
            "a zone edge (lon {west}…{east}) and the equator (lat {south}…{north})",
            "投影带边界（经度 {west}…{east}）和赤道（纬度 {south}…{north}）",
        ),
        "mb_edge_zone": ("a zone edge (lon {west}…{east})", "投影带边界（经度 {west}…{east}）"),
        "mb_edge_equator": ("the equator (lat {south}…{north})", "赤道（纬度 {south}…{north}）"),
        "mb_wrong_zone": ("{code} delivered, expected {codes}", "所交为 {code}，应为 {codes}"),
        "mb_grid_exception": (
            "{code} is the zone the UTM grid's exceptions give here (Norway, Svalbard)",
            "{code} 为 UTM 格网在此处的例外投影带（挪威、斯瓦尔巴）",
        ),
        "mb_no_epsg": (
            "block.yaml states no EPSG code (nor projection UTM with a zone such as 50N)",
            "block.yaml 未给出 EPSG 代码（也未给出 projection UTM 及 50N 之类的投影带）",
        ),
        "mb_projection_named": (
            "projection '{name}' stated beside {code}: expected {wanted}",
            "所述投影“{name}”与 {code} 不符：应为 {wanted}",
        ),
        "ph_no_ref_xy": (
            "ref_x_m and ref_y_m empty on all these checkpoints (height-only references), so no "
            "plane error",
            "这些检查点的 ref_x_m、ref_y_m 均为空（参考仅有高程），无平面误差",
        ),
        "ph_no_ref_z": (
            "ref_z_m empty on all these checkpoints (plane-only references), so no height error",
            "这些检查点的 ref_z_m 均为空（参考仅有平面位置），无高程误差",
        ),
        "ph_plane_only": (
            "the discrepancies derived from the geometry are plane only (§RC-2)",
            "依据所交几何模型推算的接边差仅有平面分量（§RC-2）",
        ),
        "ph_no_pan_ms": (
            "no PAN–MS registration table (pan_ms.csv) in the delivery",
            "成果中没有全色–多光谱配准表（pan_ms.csv）",
        ),
        "rc_convention": (
            "the delivered residuals reproduce with {convention}: RMS difference {rms} px, "
            "against {as_read} px read as the contract writes them (computed − measured, line "
            "then sample)",
            "所交残差按{convention}可以复现：差值均方根 {rms} 像素，"
            "按合同约定（计算值 − 量测值，先行后列）解读则为 {as_read} 像素",
        ),
        "rc_on_failed_geometry": (
            "RC-1 fails on the delivered geometry (the delivered residuals differ from those it "
            "gives by up to {value} px): these discrepancies, derived from it (§RC-2), may rest on "
            "a geometry in error",
            "所交几何模型未通过 RC-1（所交残差与其复算残差之差最大 {value} 像素）："
            "据其推算的这些接边差（§RC-2）可能基于有误的几何模型",
        ),
        "rc_sign": ("the opposite sign (measured − computed)", "相反符号（量测值 − 计算值）"),
        "rc_swapped": ("line and sample swapped", "行列互换"),
        "rc_sign_swapped": (
            "the opposite sign, line and sample swapped",
            "相反符号且行列互换",
        ),
        "ph_not_reproduced": (
            "tie points whose rays the delivered geometry cannot intersect: their observations "
            "are not reproduced (difference ∞, shown as –)",
            "个连接点的光线无法由所交几何模型前方交会：其观测未能复现（差值为 ∞，显示为 –）",
        ),
        "ph_no_overlaps_derived": (
            "no overlaps table (overlaps.csv), and no tie point seen on two scenes to derive the "
            "adjacent-image discrepancies from",
            "成果中没有影像重叠表（overlaps.csv），也没有位于两景及以上影像上的连接点可用于推算相邻影像接边差",
        ),
        "ph_no_overlaps": (
            "no overlaps table (overlaps.csv) in the delivery",
            "成果中没有影像重叠表（overlaps.csv）",
        ),
        "ph_no_edges": (
            "no edges table (edges.csv) in the delivery",
            "成果中没有接边表（edges.csv）",
        ),
        "ph_no_reported": (
            "block.yaml states no reported figures",
            "block.yaml 未给出报告的精度指标",
        ),
        "ph_no_scenes_bands": ("no scenes of the bands checked", "没有所检查波段的影像"),
        "ph_computed_residuals": (
            "tie-point residuals computed by blockqc from the delivered geometry (§RC-1)",
            "连接点残差由 blockqc 依据所交几何模型计算（§RC-1）",
        ),
        "ph_derived_overlaps": (
            "adjacent-image discrepancies derived by blockqc from the delivered geometry (§RC-2)",
            "相邻影像接边差由 blockqc 依据所交几何模型推算（§RC-2）",
        ),
        "ph_verified_residuals": (
            "delivered; verified against the geometry (§RC-1)",
            "成果所给，已依据几何模型验证（§RC-1）",
        ),
        "ph_residuals_computed": (
            "the delivery gives no residuals: blockqc computed them",
            "成果未给出残差，残差由 blockqc 计算",
        ),
        "ph_no_adjustment": (
            "rpc/ is given but not the producer's adjustment (adjustment.csv or rpc_adjusted/)",
            "给出了 rpc/，但没有生产单位的平差结果（adjustment.csv 或 rpc_adjusted/）",
        ),
        "ph_no_observations_checked": (
            "no tie-point observations on the scenes checked",
            "所检查的影像上没有连接点观测",
        ),
        "ph_on_other_bands": ("on scenes of other bands, not judged", "在其他波段影像上，未判定"),
        "ph_single_ray": (
            "no tie point is seen on two or more scenes",
            "没有在两景及以上影像上观测到的连接点",
        ),
        "ph_observations_single_ray": ("observations of single-ray points", "个单像点观测"),
        "ph_bands": (" (bands ", "（波段 "),
        "ph_plan_no_cps": (
            "sampled for detailed inspection, but the delivery has no checkpoints: "
            "the detailed inspection is incomplete",
            "已抽为详查样本，但成果中没有检查点：详查不完整",
        ),
        "ph_no_cps_not_sampled": (
            "no checkpoints: the block was not sampled for detailed inspection",
            "无检查点：本区域网未抽为详查样本",
        ),
        "ph_not_sampled_plan": (
            "not sampled for detailed inspection (sampling plan)",
            "未抽为详查样本（抽样方案）",
        ),
        "ph_water_fraction": ("water_fraction", "水域比例"),
        "ph_no_block_yaml": (
            "missing: every sub-folder of a batch is a delivery and needs its block.yaml "
            "(folders named '.…' are left out)",
            "缺失：批次的每个子文件夹都是一份成果，须有 block.yaml（以“.”开头的文件夹除外）",
        ),
    }
)


# --- the page of `blockqc rfm-accuracy` (§RA); CPs are the matched control points
MESSAGES.update(
    {
        "ra_title": ("RFM geometric accuracy", "有理函数模型（RFM）几何精度"),
        "ra_image_line": (
            "Image {image}, RPCs {rpc} ({format}).",
            "影像 {image}，RPC {rpc}（{format}）。",
        ),
        "ra_reference_line": (
            "Reference {file}: {how} (method {method}{gsd}).",
            "参考影像 {file}：{how}（检查方法：{method}{gsd}）。",
        ),
        "ra_reference_gsd": (", pixels of {gsd} m", "，像素大小 {gsd} m"),
        "ra_matched_on": (
            "Matched on the image's {image} and the reference's {reference}.",
            "匹配所用波段：影像为{image}，参考影像为{reference}。",
        ),
        "ra_dem_line": ("DEM {file}: {heights}.", "DEM {file}：{heights}。"),
        "ra_grid_line": (
            "Grid {crs}, GSD {gsd} m, {width} × {height} px.",
            "格网 {crs}，地面采样距离 {gsd} m，{width} × {height} 像素。",
        ),
        "ra_image_gsd_line": (
            "Errors in pixels are in the image's pixels (d_s, §RA-4): its GSD at the centre, "
            "{gsd} m, not the grid's.",
            "以像素计的误差均以影像的像素为单位（d_s，§RA-4）：即影像中心的地面采样距离 {gsd} m，"
            "而非格网的。",
        ),
        "warnings": ("Warnings", "警告"),
        "ra_matching_line": (
            "Matching (§RA-3): {n} CPs, one per {grid} px cell ({choice}).",
            "影像匹配（§RA-3）：控制点 {n} 个，每 {grid} 像素格网一个（{choice}）。",
        ),
        "ra_sec_accuracy": ("Accuracy of the whole image (§RA-4)", "整景影像精度（§RA-4）"),
        "ra_cps": ("CPs", "控制点数"),
        "ra_rmse": ("RMSE", "均方根误差 RMSE"),
        "ra_rmse_one_image": (
            "RMSE / √2 (one image, if the reference has the same accuracy)",
            "RMSE / √2（单景影像，参考影像为同精度时）",
        ),
        "ra_gev_mean_max": ("mean / max GEV", "GEV 平均值 / 最大值"),
        "ra_requirement": ("requirement", "精度要求"),
        "ra_verdict": ("verdict", "结论"),
        "ra_sec_distortion": ("Local geometric distortion (§RA-5)", "局部几何畸变（§RA-5）"),
        "ra_alt_vectors": ("CP error vectors over the image", "影像上的控制点误差矢量"),
        "ra_alt_histogram": ("GEV histogram", "GEV 直方图"),
        "ra_shift": ("systematic shift (mean vector)", "系统偏移（平均矢量）"),
        "ra_shift_value": (
            "{shift} px (dx {dx} px = {dx_m} m, dy {dy} px = {dy_m} m)",
            "{shift} 像素（dx {dx} 像素 = {dx_m} m，dy {dy} 像素 = {dy_m} m）",
        ),
        "ra_local_rms": ("RMS about the mean", "相对于平均值的均方根"),
        "ra_direction": ("direction consistency (1 = one direction)", "方向一致性（1 = 方向相同）"),
        "ra_field": ("systematic field over the image", "影像上的系统误差场"),
        "ra_field_value": (
            "{model}: explains {share} of the variance (affine alone {affine}); F = {f}, "
            "p = {p}; field RMS {rms} px",
            "{model}：解释方差的 {share}（仅仿射 {affine}）；F = {f}，p = {p}；"
            "误差场均方根 {rms} 像素",
        ),
        "ra_noise": (
            "matching noise about the field (robust spread)",
            "误差场以外的匹配噪声（稳健离散度）",
        ),
        "ra_no_field": (
            "not computed: fewer than 4 CPs (the affine field has 3 terms a component)",
            "未计算：控制点少于 4 个（仿射误差场每个分量有 3 项）",
        ),
        "ra_gev_percentiles": ("GEV median / p90 / max", "GEV 中位数 / 90% 分位数 / 最大值"),
        "ra_significant": ("significant distortion", "显著畸变"),
        "ra_not_tested": ("not tested", "未检验"),
        "ra_significance_value": (
            ": p = {p}, field RMS {rms} px",
            "：p = {p}，误差场均方根 {rms} 像素",
        ),
        "ra_significant_when": (
            " (significant when p < {alpha} and field RMS ≥ {threshold} px)",
            "（p < {alpha} 且误差场均方根 ≥ {threshold} 像素时为显著）",
        ),
        "ra_reading": ("Reading: {reading}.", "解读：{reading}。"),
        "ra_sec_refined": ("Refined RFM from k CPs (§RA-6)", "以 k 个控制点精化的 RFM（§RA-6）"),
        "ra_check_cps": ("check CPs", "检核点数"),
        "ra_draws": ("draws", "抽样次数"),
        "ra_rmse_mean": ("RMSE mean (px)", "RMSE 平均值（像素）"),
        "ra_min": ("min", "最小值"),
        "ra_max": ("max", "最大值"),
        "ra_note": ("note", "说明"),
        "ra_affine_all": (
            "Affine fitted to every CP ({note}):",
            "以全部控制点拟合的仿射变换（{note}）：",
        ),
        "ra_affine_centre": (
            "at the image centre (line {line}, sample {sample}) the correction is "
            "Δl = {dl} px, Δs = {ds} px;",
            "影像中心（行 {line}，列 {sample}）处的改正为 Δl = {dl} 像素，Δs = {ds} 像素；",
        ),
        "ra_affine_rms": ("residual RMS {rms} px.", "残差均方根 {rms} 像素。"),
        "files": ("Files", "文件"),
        "ra_conventions": (
            "Conventions: {image}; {gdal}; heights {heights}.",
            "约定：{image}；{gdal}；高程：{heights}。",
        ),
        # the figures
        "ra_fig_vectors": (
            "CP error vectors, {image} vs {reference}",
            "控制点误差矢量：{image} 对 {reference}",
        ),
        "ra_ax_gev": ("GEV (px)", "GEV（像素）"),
        "ra_ax_column": ("column (px)", "列（像素）"),
        "ra_ax_row": ("row (px)", "行（像素）"),
        "ra_ax_cps": ("CPs", "控制点数"),
        "ra_key_error": ("{px} px error", "误差 {px} 像素"),
        "px_value": ("{px} px", "{px} 像素"),
        "ra_fig_histogram": ("Geometric error value per CP", "各控制点的几何误差值（GEV）"),
        # fixed phrases of the run's results.json (English there), translated on the page
        "ra_how_ortho": (
            "orthorectified with its RPCs and the same DEM",
            "用其 RPC 和同一 DEM 正射纠正",
        ),
        "ra_how_reprojected": (
            "reprojected (bilinear) onto the image grid",
            "重投影（双线性内插）到影像格网",
        ),
        "ra_band_one": ("band 1 (one band)", "波段 1（单波段）"),
        "ra_band_first": (
            "band 1 of {count} (no bands declared red, green, blue)",
            "{count} 个波段中的波段 1（未声明红、绿、蓝波段）",
        ),
        "ra_bands_rgb_of": (
            "mean of bands {bands} (red, green, blue) of {count}",
            "{count} 个波段中波段 {bands}（红、绿、蓝）的平均值",
        ),
        "ra_bands_rgb": (
            "mean of bands {bands} (red, green, blue)",
            "波段 {bands}（红、绿、蓝）的平均值",
        ),
        "ra_heights_ellipsoidal": (
            "ellipsoidal (WGS-84) heights from {file} ({said})",
            "{file} 的椭球高（WGS-84）（{said}）",
        ),
        "ra_heights_geoid": (
            "geoid heights from {file} ({model}, {said}) + undulation N from {geoid} "
            "(N {low}..{high} m) = ellipsoidal (WGS-84)",
            "{file} 的正高（{model}，{said}）+ {geoid} 的大地水准面差距 N（N {low}..{high} m）"
            "= 椭球高（WGS-84）",
        ),
        "ra_heights_constant": ("constant ellipsoidal height {h} m", "常数椭球高 {h} m"),
        "ra_converted": ("{said}, in {unit} converted to metres", "{said}，由 {unit} 换算为米"),
        "ra_declared_by": ("declared by {how}", "由{how}声明"),
        "ra_stated_by_user": ("as stated by the user", "按用户指定"),
        "ra_stated": ("stated", "按用户指定"),
        "ra_srtm": (
            "SRTM .hgt tile (SRTM heights are above the EGM96 geoid)",
            "SRTM .hgt 图幅（SRTM 高程以 EGM96 大地水准面为基准）",
        ),
        "ra_crs_2d": ("its 2-D CRS '{name}'", "其二维坐标参考系“{name}”"),
        "ra_crs": ("its CRS '{name}'", "其坐标参考系“{name}”"),
        "ra_no_crs": ("no CRS", "无坐标参考系"),
        "ra_geoid_egm96": (
            "EGM96 (blockqc's 30' global grid, bilinear)",
            "EGM96（blockqc 自带的 30′ 全球格网，双线性内插）",
        ),
        "ra_geoid_grid": ("geoid grid {file}", "大地水准面格网 {file}"),
        "ra_geoid_constant": (
            "constant geoid undulation {n} m (--geoid-offset)",
            "常数大地水准面差距 {n} m（--geoid-offset）",
        ),
        "ra_geoid_word": ("geoid", "大地水准面"),
        "ra_grid_given": ("given", "由 --grid 指定"),
        "ra_grid_again": (
            "{how}; {n} CPs at {cell} px, so matched again at {smaller} px",
            "{how}；{cell} 像素格网仅得 {n} 个控制点，故以 {smaller} 像素重新匹配",
        ),
        "ra_grid_chosen": (
            "chosen from the image size: {cell} px for {overlap} px covered by both images "
            "(about {cells} cells, aiming at ≥ {target} CPs; {low}..{high} px)",
            "按影像大小选取：两景影像共同覆盖 {overlap} 像素，取 {cell} 像素"
            "（约 {cells} 个格网，目标 ≥ {target} 个控制点；{low}..{high} 像素）",
        ),
        "ra_reading_text": (
            "systematic distortion is significant when a low-order field of the error vectors "
            "over the image (affine in column and row, or quadratic where it adds significantly "
            "to the affine) explains a significant share of their variance against the mean shift "
            "alone (F-test, p < {alpha}) and that field varies by at least {threshold} px RMS "
            "about the mean; the scatter left about it is matching noise (its robust spread is "
            "stated), not distortion (§RA-5 gives no number)",
            "当误差矢量在影像上的低阶误差场（行列的仿射，或在仿射之外显著改进时的二次多项式）"
            "相对于仅有平均偏移时解释了其方差的显著部分（F 检验，p < {alpha}），且该误差场相对于"
            "平均值的均方根变化至少 {threshold} 像素时，系统畸变为显著；其余离散为匹配噪声"
            "（给出其稳健离散度），而非畸变（§RA-5 未给出数值）",
        ),
        "ra_model_affine": ("affine", "仿射"),
        "ra_model_quadratic": ("quadratic", "二次多项式"),
        "ra_model_none": ("not computed: fewer than {n} CPs", "未计算：控制点少于 {n} 个"),
        "ra_evaluation": (
            "RMSE (§RA-4) on the CPs not used for fitting; {repeats} random draws per k "
            "(seed {seed})",
            "在未参与拟合的控制点上计算 RMSE（§RA-4）；每个 k 随机抽样 {repeats} 次"
            "（随机种子 {seed}）",
        ),
        "ra_note_original": ("original RFM", "原始 RFM"),
        "ra_note_needs": ("needs 3 ≤ k < n CPs (n = {n})", "需要 3 ≤ k < n 个控制点（n = {n}）"),
        "ra_note_refined": (
            "refined RFM (image-space affine), held-out CPs",
            "精化 RFM（像方仿射变换），留出的控制点",
        ),
        "ra_note_few_checks": ("{note}; only {n} check CPs", "{note}；仅 {n} 个检核点"),
        "ra_note_collinear": (
            "{note}; {n} draws with collinear CPs left out",
            "{note}；剔除控制点共线的抽样 {n} 次",
        ),
        "ra_all_cps_note": (
            "image-space affine (§3) fitted to every CP; its residual is in-sample",
            "像方仿射变换（§3）；全部控制点参与拟合，其残差为样本内残差",
        ),
        "ra_convention_image": (
            "pixel centre, first pixel (0, 0), full-image coordinates of the RPCs",
            "像素中心，首像素为 (0, 0)，采用 RPC 的全幅影像坐标",
        ),
        "ra_convention_gdal": (
            "GDAL's RPC transformer uses pixel corners: GDAL = ours + 0.5 px",
            "GDAL 的 RPC 变换以像素角点为准：GDAL = 本程序 + 0.5 像素",
        ),
        "ra_convention_heights": ("WGS-84 ellipsoidal", "WGS-84 椭球高"),
        # the run's warnings (results.json "warnings", English there), translated on the page
        "ra_warn_no_height": (
            "{share} of the image has no height from the DEM {dem} ({parts}): those pixels stay "
            "empty in ortho.tif and give no CP",
            "影像的 {share} 在 DEM {dem} 上没有高程（{parts}）：这些像素在 ortho.tif 中为空，"
            "不产生控制点",
        ),
        "ra_warn_outside": ("{outside} outside it", "{outside} 在其范围之外"),
        "ra_warn_voids": (
            "{void} on its voids (--dem-fill-voids N closes small ones)",
            "{void} 位于其数据空洞处（--dem-fill-voids N 可填补较小的空洞）",
        ),
        "ra_warn_outside_voids": (
            "{outside} outside it, {void} on its voids (--dem-fill-voids N closes small ones)",
            "{outside} 在其范围之外，{void} 位于其数据空洞处"
            "（--dem-fill-voids N 可填补较小的空洞）",
        ),
        "ra_warn_few_cps": (
            "§RA-3: only {n} CPs with a {cell} px cell ({how}): the texture or the overlap "
            "allows no more at this cell; a smaller --grid may find more",
            "§RA-3：{cell} 像素格网（{how}）仅得到 {n} 个控制点：在此格网下，影像纹理或重叠范围"
            "不能提供更多控制点；减小 --grid 或可找到更多",
        ),
        "ra_grid_chosen_word": ("chosen", "自动选取"),
        "ra_warn_dem_ellipsoid": (
            "the DEM was taken as ellipsoidal on --dem-vertical ellipsoid alone: if it holds "
            "geoid heights every height is off by N (tens of metres) and the image by metres",
            "仅凭 --dem-vertical ellipsoid 将 DEM 视为椭球高：若其高程以大地水准面为基准，"
            "则所有高程均偏差 N（数十米），影像偏差达数米",
        ),
        "ra_warn_reference_gsd": (
            "§RA-2: the reference's pixels cover {ref} m, {ratio}× the image's GSD ({gsd} m; "
            "more than {limit}×): matched on the image's grid it is interpolated, and errors of "
            "a fraction of its pixel — several image pixels — go unseen; use a reference at "
            "least as fine as the image",
            "§RA-2：参考影像的像素大小为 {ref} m，是影像地面采样距离（{gsd} m）的 {ratio} 倍"
            "（超过 {limit} 倍）：在影像格网上匹配时参考影像须经内插，其像素几分之一的误差"
            "（相当于影像的若干像素）无法发现；请使用分辨率不低于影像的参考影像",
        ),
        "ra_warn_k_unsupported": (
            "§RA-6: k = {k} needs more than {k} CPs, only {n} found: row left empty",
            "§RA-6：k = {k} 需要多于 {k} 个控制点，仅找到 {n} 个：该行留空",
        ),
        "ra_warn_k_few_checks": (
            "§RA-6: k = {k} leaves {left} CPs to check on (< {min}): its RMSE is a rough figure",
            "§RA-6：k = {k} 仅留下 {left} 个检核点（< {min}）：其 RMSE 仅供粗略参考",
        ),
    }
)


# --- the page of `blockqc adjust` (§RC-3)
MESSAGES.update(
    {
        "ad_page_title": ("Block adjustment (recalculation)", "区域网平差（重新计算）"),
        "ad_title": ("RFM-affine block adjustment", "RFM 仿射区域网平差"),
        "ad_intro": (
            "Independent recalculation (§RC-3) of the delivery {delivery} from its original\n"
            "RPCs and tie observations alone; residuals v = computed − measured in image pixels.",
            "仅用成果 {delivery} 的原始 RPC 和连接点观测独立重新计算（§RC-3）；"
            "残差 v = 计算值 − 量测值，以影像像素计。",
        ),
        "ad_sec_result": ("Result", "平差结果"),
        "ad_converged": ("converged", "是否收敛"),
        "ad_iterations": ("iterations", "迭代次数"),
        "ad_kept": ("scenes / points / observations kept", "保留的影像 / 点 / 观测数"),
        "ad_observations_delivered": ("observations in the delivery", "成果中的观测数"),
        "ad_outliers": ("outliers rejected (|v| > k·σ0)", "剔除的粗差观测（|v| > k·σ0）"),
        "ad_without_second_ray": (
            "observations left without a second ray",
            "剔除后失去第二条光线的观测",
        ),
        "ad_sigma0": ("σ0 a posteriori (image measurement)", "验后单位权中误差 σ0（像点量测）"),
        "ad_rms_before": ("residual RMS before (original RPCs)", "平差前残差均方根（原始 RPC）"),
        "ad_rms_after": ("residual RMS after", "平差后残差均方根"),
        "ad_time": ("time", "耗时"),
        "ad_seconds": ("{s} s", "{s} 秒"),
        "ad_sec_datum": ("Datum (no ground control)", "平差基准（无地面控制点）"),
        "ad_height": ("Height: {prior}", "高程：{prior}"),
        "ad_fixed": ("Fixed scenes: {scenes}", "固定的影像：{scenes}"),
        "ad_sec_convergence": ("Convergence", "收敛过程"),
        "ad_alt_convergence": ("convergence", "收敛过程"),
        "ad_sec_residuals": ("Residuals", "残差"),
        "ad_alt_histograms": ("residual histograms", "残差直方图"),
        "ad_alt_vectors": ("residual vectors over the block", "区域网残差矢量"),
        "ad_alt_scene_vectors": (
            "residual vector map per scene, largest RMS first",
            "各影像残差矢量图，均方根最大者在前",
        ),
        "ad_sec_checkpoints": (
            "Checkpoints for the recalculation method (§CP-1, §RC-3)",
            "其他软件重新计算法检查点（§CP-1、§RC-3）",
        ),
        "ad_checkpoints_text": (
            "{n} well-spread points: the producer's position ({source})\n"
            "against the recalculated one, in EPSG:{epsg} ({crs_source}), written to\n"
            "{file} for {command}.",
            "{n} 个分布均匀的点：生产单位的平差位置（{source}）与重新计算的位置比较，"
            "坐标系 EPSG:{epsg}（{crs_source}），写入 {file}，供 {command} 使用。",
        ),
        "ad_sec_scenes": ("Per-scene precision", "各影像精度"),
        "ad_alt_precision": ("per-scene precision", "各影像精度"),
        "ad_col_scene": ("scene", "影像"),
        "ad_col_obs": ("obs.", "观测数"),
        "ad_col_outliers": ("outliers", "粗差数"),
        "ad_col_without": ("without a second ray", "无第二条光线"),
        "ad_col_rms": ("RMS (px)", "均方根（像素）"),
        "ad_col_a0": ("a0 (px)", "a0（像素）"),
        "ad_col_sigma_a0": ("σ a0 (px)", "σ a0（像素）"),
        "ad_col_b0": ("b0 (px)", "b0（像素）"),
        "ad_col_sigma_b0": ("σ b0 (px)", "σ b0（像素）"),
        "ad_col_sigma_shift": ("σ shift at centre (px)", "影像中心平移量的 σ（像素）"),
        # the figures
        "ad_lg_rms": ("RMS |f| (px)", "|f| 的均方根（像素）"),
        "ad_lg_update": ("largest update (px)", "最大改正量（像素）"),
        "ad_ax_iteration": (
            "iteration (Huber, then least squares after rejection)",
            "迭代次数（先 Huber 抗差，剔除粗差后最小二乘）",
        ),
        "ad_ax_log_px": ("px (log scale)", "像素（对数刻度）"),
        "ad_fig_before": ("|v| before adjustment (px)", "平差前 |v|（像素）"),
        "ad_fig_after": ("|v| after adjustment (px)", "平差后 |v|（像素）"),
        "ad_ax_clipped": ("px (clipped at the 99.5th percentile)", "像素（截断于 99.5% 分位数）"),
        "ad_fig_vectors": (
            "residual vectors (sample →, line ↓), scene outlines in grey",
            "残差矢量（列 →，行 ↓），灰色为影像范围",
        ),
        "ad_fig_scene_vectors": (
            "mean residual per {k}×{k} cell of the {n} scenes of largest RMS "
            "(image space; longest arrow {ref} px)",
            "均方根最大的 {n} 景影像各 {k}×{k} 格网的平均残差（像方；最长箭头 {ref} 像素）",
        ),
        "ad_no_kept": ("no kept observation", "无保留的观测"),
        "ad_ax_sigma_shift": (
            "σ of the shift at the image centre (px)",
            "影像中心平移量的 σ（像素）",
        ),
        "ad_fig_precision": (
            "per-scene precision (scene centre = mean of its tie points)",
            "各影像精度（影像中心取其连接点的平均位置）",
        ),
        # fixed phrases of adjust.json (English there), translated on the page
        "ad_affine_priors": (
            "a-priori RPC accuracy: σ {shift} px for a0, b0 (shift at the image centre), "
            "σ {linear} px at the image edge for the linear terms",
            "RPC 先验精度：a0、b0（影像中心处的平移）σ {shift} 像素，"
            "线性项在影像边缘处 σ {linear} 像素",
        ),
        "ad_prior_elsewhere": ("{dem}; elsewhere {weak}", "{dem}；其余点：{weak}"),
        "ad_prior_weak": (
            "weak height prior: the block's mean height {h} ± {sigma} m (mean HEIGHT_OFF ± "
            "largest HEIGHT_SCALE), ± {each} m at each of its {n} points",
            "弱高程先验：区域网平均高程 {h} ± {sigma} m（HEIGHT_OFF 的平均值 ± "
            "最大的 HEIGHT_SCALE），{n} 个点每点 ± {each} m",
        ),
        "ad_prior_dem": (
            "DEM height prior ± {sigma} m from {file} ({heights}) at {on} of {n} points",
            "DEM 高程先验 ± {sigma} m，取自 {file}（{heights}），用于 {n} 个点中的 {on} 个",
        ),
        "ad_producer_delivered": (
            "tie_points.csv lon, lat, h (delivered)",
            "tie_points.csv 的 lon、lat、h（成果所给）",
        ),
        "ad_producer_none": (
            "none (no lon/lat/h in tie_points and no producer adjustment)",
            "无（tie_points 中没有 lon/lat/h，也没有生产单位的平差结果）",
        ),
        "ad_producer_intersected": (
            "intersection with the producer's adjustment ({source})",
            "按生产单位的平差结果（{source}）前方交会",
        ),
        "ad_crs_block": (
            "block.yaml spatial_reference.epsg",
            "block.yaml 的 spatial_reference.epsg",
        ),
        "ad_crs_utm": (
            "UTM zone of the block centre (block.yaml gives no projected EPSG)",
            "区域网中心所在的 UTM 投影带（block.yaml 未给出投影坐标系的 EPSG）",
        ),
        "ad_crs_utm_not_metres": (
            "UTM zone of the block centre (block.yaml's EPSG:{epsg} is not in metres)",
            "区域网中心所在的 UTM 投影带（block.yaml 的 EPSG:{epsg} 不以米为单位）",
        ),
        "ad_crs_ups": (
            "UPS of the block centre's pole (block.yaml gives no projected EPSG)",
            "区域网中心所在极区的 UPS 投影（block.yaml 未给出投影坐标系的 EPSG）",
        ),
        "ad_crs_ups_not_metres": (
            "UPS of the block centre's pole (block.yaml's EPSG:{epsg} is not in metres)",
            "区域网中心所在极区的 UPS 投影（block.yaml 的 EPSG:{epsg} 不以米为单位）",
        ),
        "ad_cps_none": (
            "no point could be compared, so checkpoints.csv holds its header only: the "
            "producer's positions come from tie_points lon/lat/h or from its adjustment "
            "(adjustment.csv, rpc_adjusted/)",
            "没有可比较的点，checkpoints.csv 只有表头：生产单位的位置取自 tie_points 的 "
            "lon/lat/h 或其平差结果（adjustment.csv、rpc_adjusted/）",
        ),
        "ad_cps_few": (
            "only {n} points could be compared (§CP-1 asks for 20–50)",
            "仅 {n} 个点可比较（§CP-1 要求 20–50 个）",
        ),
        # the run's warnings (adjust.json "warnings", English there), translated on the page
        "ad_warn_narrow_rays": (
            "{n} of {used} points are seen along rays with a base-to-height ratio below {min} "
            "(median {median}; near-identical viewing directions): the images fix no height for "
            "them (σ_h median {sigma} m), so their heights are the weak height prior's and the "
            "{among} checkpoints among them check no height; give --dem for a height prior",
            "{used} 个点中有 {n} 个点的光线基高比小于 {min}（中位数 {median}；观测方向几乎相同）："
            "影像无法确定这些点的高程（σ_h 中位数 {sigma} m），其高程取决于弱高程先验，"
            "其中的 {among} 个检查点不能检查高程；请用 --dem 给出高程先验",
        ),
        "ad_warn_scene": (
            "scene {scene} {why}: its affine is set by the priors alone, not by the data; check "
            "its RPC (rpc/) and its tie points",
            "影像 {scene} {why}：其仿射参数仅由先验确定，而非由数据确定；请检查其 RPC（rpc/）"
            "及其连接点",
        ),
        "ad_warn_scene_empty": ("has no tie-point observation", "没有连接点观测"),
        "ad_warn_left_out": (
            "{n} scene(s) of scenes.csv left out of the adjustment, not adjusted: {scenes}: "
            "without a tie-point observation nothing ties a scene to the block, whatever its "
            "RPC; adjustment.csv gives them no affine (adjusted false)",
            "scenes.csv 中有 {n} 景影像未参与平差，未作平差：{scenes}：没有连接点观测的影像与区域网"
            "之间无任何联系，无论其 RPC 如何；adjustment.csv 中没有其仿射参数（adjusted 为 false）",
        ),
        "ad_not_adjusted": ("not adjusted: {why}", "未作平差：{why}"),
        "ad_warn_scene_few": (
            "keeps {kept} of its {total} observations after outlier rejection (fewer than {min}; "
            "{outliers} outliers, {single} left without a second ray)",
            "经粗差剔除后，其 {total} 个观测仅保留 {kept} 个（少于 {min} 个；粗差 {outliers} 个，"
            "{single} 个失去第二条光线）",
        ),
        "ad_warn_sigma0": (
            "σ0 {sigma0} px, far above a tie-point measurement precision (above {max} px): the "
            "RPCs (rpc/) and the tie points do not fit one another; check that each scene's RPC "
            "is its own",
            "σ0 为 {sigma0} 像素，远高于连接点的量测精度（超过 {max} 像素）：RPC（rpc/）与连接点"
            "互不相符；请检查每景影像的 RPC 是否确为其本身的 RPC",
        ),
        "ad_warn_datum": (
            "the datum is barely held: the recalculated points' plane σ is {plane} m (median; "
            "height {height} m), beyond {max} m, the bound 2√2·m of the recalculation method's "
            "checkpoints (§CP-4, m = {norm} m): the priors on the affine parameters "
            "(--sigma-shift, --sigma-linear, --fix) leave the block free to move, and its "
            "checkpoints check nothing; give the RPCs' a-priori accuracy",
            "平差基准几乎未被约束：重算点的平面 σ 为 {plane} m（中位数；高程 {height} m），超过 "
            "{max} m，即重算法检查点的限差 2√2·m（§CP-4，m = {norm} m）：仿射参数的先验"
            "（--sigma-shift、--sigma-linear、--fix）使区域网可以整体移动，其检查点不能检查任何"
            "内容；请给出 RPC 的先验精度",
        ),
        "ad_warn_prior": (
            "{n} scene(s) corrected far beyond the a-priori σ of their RPCs (the shift at the "
            "image centre against --sigma-shift, or a linear term at the image edge against "
            "--sigma-linear, more than {excess} times): {named}; no RPC bias is believed that "
            "large: check that each scene's RPC (rpc/) is its own and its tie points' image "
            "coordinates are in its pixels, or give the RPCs' real a-priori accuracy",
            "{n} 景影像的改正量远超其 RPC 的先验 σ（影像中心平移相对 --sigma-shift，或影像边缘"
            "线性项相对 --sigma-linear，超过 {excess} 倍）：{named}；RPC 的偏差不应如此之大："
            "请检查每景影像的 RPC（rpc/）是否确为其本身的 RPC、其连接点的像方坐标是否为该影像的"
            "像素坐标，或给出 RPC 的实际先验精度",
        ),
        "ad_warn_prior_more": (
            "{n} scene(s) corrected far beyond the a-priori σ of their RPCs (the shift at the "
            "image centre against --sigma-shift, or a linear term at the image edge against "
            "--sigma-linear, more than {excess} times): {named}, and {more} more "
            "(adjustment.csv); no RPC bias is believed that large: check that each scene's RPC "
            "(rpc/) is its own and its tie points' image coordinates are in its pixels, or give "
            "the RPCs' real a-priori accuracy",
            "{n} 景影像的改正量远超其 RPC 的先验 σ（影像中心平移相对 --sigma-shift，或影像边缘"
            "线性项相对 --sigma-linear，超过 {excess} 倍）：{named}，另有 {more} 景"
            "（adjustment.csv）；RPC 的偏差不应如此之大：请检查每景影像的 RPC（rpc/）是否确为"
            "其本身的 RPC、其连接点的像方坐标是否为该影像的像素坐标，或给出 RPC 的实际先验精度",
        ),
        "ad_warn_all_held": (
            "all {n} scenes are held (--fix): nothing is adjusted; the points are the "
            "intersections of the RPCs as delivered, and the checkpoints compare the producer's "
            "positions with those, not with a recalculation",
            "全部 {n} 景影像均被固定（--fix）：未作任何平差；各点为按交付 RPC 前方交会所得，"
            "检查点比较的是生产方的位置与这些交会点，而非重算结果",
        ),
        "ad_warn_rms_grew": (
            "the residual RMS grew in the adjustment ({before} → {after} px): the corrections "
            "the data ask for are beyond the priors, or the data do not fit",
            "平差后残差均方根反而增大（{before} → {after} 像素）：数据所要求的改正超出了先验范围，"
            "或数据互不相符",
        ),
    }
)


# --- the page of `blockqc factors` (§AF)
MESSAGES.update(
    {
        "af_page_title": (
            "What drives accuracy: factors and indicators (§AF)",
            "精度影响因素：平差因素与精度指标（§AF）",
        ),
        "af_title": ("What drives a block's accuracy", "区域网精度的影响因素"),
        "af_intro": (
            "Adjustment factors and accuracy indicators, DOMAIN.md §5 (§AF). Source: {source}.",
            "平差因素与精度指标，DOMAIN.md §5（§AF）。数据来源：{source}。",
        ),
        "af_rows_one": (
            "{n} experiment in the table, {used} complete and used.",
            "表中共 {n} 个试验，其中 {used} 个数据完整并参与分析。",
        ),
        "af_rows": (
            "{n} experiments in the table, {used} complete and used.",
            "表中共 {n} 个试验，其中 {used} 个数据完整并参与分析。",
        ),
        "af_excluded": (
            "Rows left out of the canonical correlation analysis because a factor or indicator "
            "is missing (the correlations below use, cell by cell, every row where both values "
            "are present):",
            "因缺少某个因素或指标而未参与典型相关分析的行（下面的相关系数逐格使用两个值均存在的"
            "所有行）：",
        ),
        "af_missing": ("no {columns}", "缺少 {columns}"),
        "af_excluded_why": (
            "δ_X, δ_Y, δ_H come from checkpoints (checkpoints.csv), which only the sampled "
            "blocks carry; the terrain factors need a DEM over the block.",
            "δ_X、δ_Y、δ_H 来自检查点（checkpoints.csv），只有抽样区域网才有；"
            "地形因素需要覆盖区域网的 DEM。",
        ),
        "af_sec_correlation": (
            "1. Pearson correlation of each factor with each indicator",
            "1. 各因素与各指标的 Pearson 相关系数",
        ),
        "af_correlation_how": (
            "r over the experiments where both values are present ({n}); p from the two-sided "
            "t-test with n − 2 degrees of freedom. Bold: p < 0.05.",
            "r 按两个值均存在的试验计算（{n}）；p 由自由度为 n − 2 的双侧 t 检验得出。"
            "粗体：p < 0.05。",
        ),
        "af_n_cells": ("n = {low}–{high} per cell", "每格 n = {low}–{high}"),
        "af_factor": ("factor", "因素"),
        "af_indicator": ("indicator", "指标"),
        "af_sec_cca": (
            "2. Canonical correlation analysis: factors (U) against indicators (V)",
            "2. 典型相关分析：因素（U）与指标（V）",
        ),
        "af_cca_pairs": (
            "{pairs} canonical pairs from n = {n} experiments, p = {p} factors, "
            "q = {q} indicators.",
            "由 n = {n} 个试验、p = {p} 个因素和 q = {q} 个指标得到 {pairs} 对典型变量。",
        ),
        "af_bartlett": (
            "Bartlett's test of pairs k … m: {formula}, with (p − k + 1)(q − k + 1) degrees of "
            "freedom.",
            "第 k … m 对的 Bartlett 检验：{formula}，自由度为 (p − k + 1)(q − k + 1)。",
        ),
        "af_pair": ("pair k", "第 k 对"),
        "af_canonical_r": ("canonical r", "典型相关系数 r"),
        "af_wilks": ("Wilks' Λ", "Wilks Λ"),
        "af_df": ("df", "自由度"),
        "af_structure": (
            "Structure coefficients on the first canonical variates",
            "第一对典型变量上的结构系数",
        ),
        "af_structure_how": (
            "Correlation of each variable with the first canonical variate of its own group "
            "(U1 for factors, V1 for indicators) and of the other group. |value| ≥ 0.5 is "
            "usually read as a strong contribution.",
            "各变量与本组第一典型变量（因素为 U1，指标为 V1）及另一组第一典型变量的相关系数。"
            "|值| ≥ 0.5 通常视为贡献较大。",
        ),
        "af_on": ("on {variate}", "在 {variate} 上"),
        "af_coefficient": ("standardized coefficient {variate}", "{variate} 的标准化系数"),
        "af_coefficients_file": (
            "Coefficients of every canonical pair are in {file}.",
            "各对典型变量的系数见 {file}。",
        ),
        "af_no_cca": ("CCA not computed.", "未进行典型相关分析。"),
        "af_no_cca_then": (
            "The correlation matrix above is still shown. Run {command} on a table with enough "
            "experiments (one row per block or adjustment run) for the full analysis.",
            "上面仍给出相关矩阵。对试验足够多的表（每个区域网或每次平差一行）运行 {command}"
            " 可得完整分析。",
        ),
        "af_sec_experiments": ("3. The experiments", "3. 试验数据"),
        "af_summary": ("Summary of the columns analysed", "参与分析各列的统计"),
        "af_column": ("column", "列"),
        "af_mean": ("mean", "平均值"),
        "af_sd": ("sd", "标准差"),
        "af_rests_on": ("What the figures rest on", "数值的依据"),
        "af_sec_definitions": ("Definitions", "定义"),
        "af_def_indicators": (
            "Indicators: RMSE about the mean (m − 1 denominator) of the tie-point residuals "
            "{vl}, {vs} (px) and of the checkpoint differences in X, Y, H (m).",
            "指标：连接点残差 {vl}、{vs}（像素）及检查点 X、Y、H 差值（m）相对于平均值的"
            "均方根误差（分母为 m − 1）。",
        ),
        "af_def_terrain": (
            "Terrain: mean elevation, mean slope (Horn's 3×3 stencil) and mean roughness "
            "(max − min in the 3×3 window) over the block's covered area, area-weighted.",
            "地形：区域网覆盖范围内按面积加权的平均高程、平均坡度（Horn 3×3 算子）和平均粗糙度"
            "（3×3 窗口内最大值 − 最小值）。",
        ),
        "af_def_images": (
            "Covered area: area of the union of the image footprints on an equal-area "
            "projection. Overlap degree: area seen by two or more footprint units / covered "
            "area, a unit being one stereo acquisition (same day, nearly the same footprint) or "
            "one single image; image pairs: the number of such units. Periods: distinct "
            "acquisition dates.",
            "覆盖面积：影像范围在等积投影下的并集面积。重叠度：被两个及以上影像单元覆盖的面积 / "
            "覆盖面积，一个单元为一次立体获取（同一天、范围几乎相同）或一景单独的影像；像对数："
            "此类单元的个数。时相：不同的获取日期。",
        ),
        "af_def_tie_points": (
            "Tie points: number of distinct points; density per km² of covered area; "
            "Clark–Evans R = mean nearest-neighbour distance / (0.5 / √density).",
            "连接点：不同点的个数；每平方千米覆盖面积的点数（密度）；"
            "Clark–Evans R = 平均最近邻距离 / (0.5 / √密度)。",
        ),
        "af_def_correlations": (
            "Correlations use, cell by cell, the experiments where both values are present; "
            "the CCA uses the experiments where all fifteen are.",
            "相关系数逐格使用两个值均存在的试验；典型相关分析使用十五个值全部存在的试验。",
        ),
        # the factors and indicators (results' labels in English) and the other columns
        "af_label_mean_elevation_m": ("mean elevation (m)", "平均高程（m）"),
        "af_label_mean_slope_deg": ("mean slope (°)", "平均坡度（°）"),
        "af_label_mean_roughness_m": ("mean roughness (m)", "平均粗糙度（m）"),
        "af_label_images_area_km2": ("covered area (km²)", "覆盖面积（km²）"),
        "af_label_images_number": ("number of images", "影像数"),
        "af_label_images_periods": ("acquisition periods", "获取时相数"),
        "af_label_overlap_degree": ("overlap degree", "重叠度"),
        "af_label_tp_number": ("tie-point number", "连接点数"),
        "af_label_tp_density_per_km2": ("tie-point density (/km²)", "连接点密度（/km²）"),
        "af_label_l_rmse_px": ("δ_l (px)", "δ_l（像素）"),
        "af_label_s_rmse_px": ("δ_s (px)", "δ_s（像素）"),
        "af_label_x_rmse_m": ("δ_X (m)", "δ_X（m）"),
        "af_label_y_rmse_m": ("δ_Y (m)", "δ_Y（m）"),
        "af_label_h_rmse_m": ("δ_H (m)", "δ_H（m）"),
        "af_col_experiment": ("experiment", "试验"),
        "af_col_region": ("region", "区域"),
        "af_col_periods": ("periods", "时相"),
        "af_col_image_pairs": ("image pairs", "像对数"),
        "af_col_sensor": ("sensor", "传感器"),
        "af_col_dem_coverage": ("dem coverage", "DEM 覆盖率"),
        "af_col_dem_files": ("dem files", "DEM 文件"),
        "af_col_overlap_union": ("overlap union", "重叠度（并集）"),
        "af_col_overlap_pairwise_sum": ("overlap pairwise sum", "重叠度（逐对求和）"),
        "af_col_overlapping_pairs": ("overlapping pairs", "重叠像对数"),
        "af_col_n_tie_observations": ("n tie observations", "连接点观测数"),
        "af_col_residual_band": ("residual band", "残差所用波段"),
        "af_col_n_plane_checkpoints": ("n plane checkpoints", "平面检查点数"),
        "af_col_n_height_checkpoints": ("n height checkpoints", "高程检查点数"),
        "af_col_plane_method": ("plane method", "平面检查方法"),
        "af_col_height_method": ("height method", "高程检查方法"),
        "af_col_delivery": ("delivery", "成果"),
        "af_band_all": ("all", "全部波段"),
        # the figures
        "af_ax_pearson": ("Pearson r", "Pearson 相关系数 r"),
        "af_fig_correlation": ("{n}; * p < 0.05", "{n}；* p < 0.05"),
        "af_fig_factors": (
            "factors on U1 (bars), on V1 (dots)",
            "因素：在 U1 上（条形），在 V1 上（圆点）",
        ),
        "af_fig_indicators": (
            "indicators on V1 (bars), on U1 (dots)",
            "指标：在 V1 上（条形），在 U1 上（圆点）",
        ),
        "af_ax_structure": ("structure coefficient", "结构系数"),
        "af_fig_first_pair": ("First canonical pair, {r}", "第一对典型变量，{r}"),
        # fixed phrases of factors.json (English there), translated on the page
        "af_few_values": (
            "fewer than {n} values, no correlation: {columns}",
            "少于 {n} 个值，无相关系数：{columns}",
        ),
        "af_constant": (
            "constant over the experiments, no correlation: {columns}",
            "在各试验中为常数，无相关系数：{columns}",
        ),
        "af_nearly_constant": (
            "varying by less than 0.1 % of their mean, so their correlations rest on very small "
            "differences: {columns}",
            "变化小于其平均值的 0.1%，其相关系数仅取决于极小的差异：{columns}",
        ),
        "af_needs_rows": (
            "the table has n = {n} complete rows but CCA of p = {p} factors and q = {q} "
            "indicators needs n − 1 > p + q, i.e. at least {rows} rows (with fewer, some "
            "canonical correlation is 1 by construction and Bartlett's statistic is undefined)",
            "表中有 n = {n} 个完整的行，但 p = {p} 个因素与 q = {q} 个指标的典型相关分析需要 "
            "n − 1 > p + q，即至少 {rows} 行（行数更少时，必有典型相关系数为 1，"
            "Bartlett 统计量无定义）",
        ),
        "af_constant_group": (
            "constant {group} column(s): {columns}",
            "为常数的{group}列：{columns}",
        ),
        "af_combination": (
            "{group} column {column} is (numerically) a linear combination of {others}",
            "{group}列 {column}（在数值上）是 {others} 的线性组合",
        ),
        "af_the_others": ("the others", "其他列"),
        "af_collinear": (
            "the first canonical correlation is 1, so a combination of the factors reproduces a "
            "combination of the indicators exactly (collinear groups)",
            "第一典型相关系数为 1，即因素的某一组合与指标的某一组合完全一致（两组共线）",
        ),
    }
)


def translator(lang: str) -> Callable[..., str]:
    """`t(key, **values)`: the label in `lang`, formatted; unknown keys are a defect, loudly."""
    if lang not in LANGUAGES:
        raise ValueError(f"language {lang!r}: choose one of {', '.join(LANGUAGES)}")
    index = LANGUAGES.index(lang)

    def t(key: str, **values: object) -> str:
        text = MESSAGES[key][index]
        return text.format(**values) if values else text

    return t


def catalogue_characters() -> str:
    """Every character the catalogue uses (the font subset must cover them)."""
    return "".join(sorted({c for en, zh in MESSAGES.values() for c in en + zh}))
