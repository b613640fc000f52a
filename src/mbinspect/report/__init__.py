"""Figures and self-contained HTML reports (images embedded, readable offline), and GIS layers.

Examples
--------
>>> from mbinspect.report import html_table
>>> print(html_table([{"a": 1, "b": 2.5}], ["a", "b"]).splitlines()[0])
<div class='wide'><table>
"""

from .gis import crs_label, crs_of, lonlat_transform, write_geojson, write_gis
from .html import html_page, html_table, json_dumps
from .maps import plan_image, save_figure
from .piles import pile_figures, pile_outputs, spacing_table, write_pile_outputs
from .reefs import reef_figures, reef_outputs, write_reef_outputs
from .writers import WRITERS, Outputs, write_outputs

__all__ = ["html_table", "html_page", "json_dumps", "save_figure", "plan_image", "pile_figures",
           "spacing_table", "write_pile_outputs", "reef_figures", "write_reef_outputs", "crs_of", "crs_label",
           "lonlat_transform", "write_geojson", "write_gis", "Outputs", "WRITERS", "write_outputs",
           "pile_outputs", "reef_outputs"]
