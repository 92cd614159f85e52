"""A confusion matrix as a heatmap PNG, drawn with Pillow (the ``study`` extra)."""

from __future__ import annotations

import io

from mse.extras import require
from mse.study.analysis.analyze import Confusion

_CELL = 44
_FONT_SIZE = 13


def heatmap_png(confusion: Confusion) -> bytes:
    """Row percentages of ``confusion`` (rows: emotion shown, columns: label chosen), darker = more,
    with the percentage written in every cell."""
    with require("study"):
        from PIL import Image, ImageDraw, ImageFont

    font = ImageFont.load_default(size=_FONT_SIZE)
    probe = ImageDraw.Draw(Image.new("RGB", (1, 1)))

    def width(text: str) -> int:
        return int(probe.textlength(text, font=font))

    left = max(width(name) for name in (*confusion.emotions, "shown")) + 16
    top = max(width(name) for name in (*confusion.labels, "chosen")) + 16
    title = f"{confusion.condition}: rows = emotion shown, columns = label chosen, % of the row"
    columns, rows = len(confusion.labels), len(confusion.emotions)
    image = Image.new("RGB", (max(left + columns * _CELL + 8, width(title) + 16), top + rows * _CELL + 30), "white")
    draw = ImageDraw.Draw(image)
    draw.text((8, image.height - 22), title, fill="black", font=font)
    for column, label in enumerate(confusion.labels):  # column names written upwards
        upright = Image.new("RGBA", (width(label) + 4, _FONT_SIZE + 6), (255, 255, 255, 0))
        ImageDraw.Draw(upright).text((2, 1), label, fill="black", font=font)
        rotated = upright.rotate(90, expand=True)
        image.paste(rotated, (left + column * _CELL + (_CELL - rotated.width) // 2, top - 6 - rotated.height), rotated)
    for row, (emotion, counts) in enumerate(zip(confusion.emotions, confusion.counts, strict=True)):
        y = top + row * _CELL
        draw.text((left - 8 - width(emotion), y + (_CELL - _FONT_SIZE) // 2), emotion, fill="black", font=font)
        total = sum(counts) or 1
        for column, count in enumerate(counts):
            share = count / total
            shade = round(255 * (1 - share))
            x = left + column * _CELL
            draw.rectangle((x, y, x + _CELL - 1, y + _CELL - 1), fill=(shade, shade, 255), outline=(200, 200, 200))
            text = f"{round(100 * share)}"
            draw.text((x + (_CELL - width(text)) // 2, y + (_CELL - _FONT_SIZE) // 2), text,
                      fill="white" if share > 0.55 else "black", font=font)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG", optimize=True)
    return buffer.getvalue()
