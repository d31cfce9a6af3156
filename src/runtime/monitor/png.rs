//! The monitor's screen as a PNG (the README's screenshot): ratatui's test-backend
//! buffer drawn cell by cell with plotters and the project's embedded font; box and
//! braille characters (borders, the plot) are drawn as lines and dots, so the image
//! needs no terminal font.

use super::model::{Snapshot, Tracker};
use plotters::prelude::*;
use ratatui::style::Color as Tui;
use std::path::{Path, PathBuf};

/// Cell size [px].
const CW: i32 = 9;
const CH: i32 = 18;
/// Screen size [cells].
const COLS: u16 = 150;
const LINES: u16 = 46;

#[derive(Debug, thiserror::Error)]
#[error("cannot draw {}: {message}", path.display())]
pub struct PngError {
    pub path: PathBuf,
    pub message: String,
}

fn rgb(c: Tui, fg: bool) -> RGBColor {
    match c {
        Tui::Reset => {
            if fg {
                RGBColor(220, 220, 220)
            } else {
                RGBColor(24, 24, 28)
            }
        }
        Tui::Black => RGBColor(24, 24, 28),
        Tui::Red => RGBColor(220, 80, 80),
        Tui::Green => RGBColor(90, 200, 90),
        Tui::Yellow => RGBColor(230, 200, 60),
        Tui::Blue => RGBColor(60, 110, 200),
        Tui::Magenta => RGBColor(200, 90, 200),
        Tui::Cyan => RGBColor(80, 200, 220),
        Tui::Gray => RGBColor(160, 160, 160),
        Tui::DarkGray => RGBColor(100, 100, 100),
        Tui::White => RGBColor(240, 240, 240),
        Tui::Rgb(r, g, b) => RGBColor(r, g, b),
        _ => RGBColor(200, 200, 200),
    }
}

/// Draw the screen of `snap` to `path`.
pub fn write(snap: &Snapshot, t: &Tracker, path: &Path) -> Result<(), PngError> {
    let fail = |e: &dyn std::fmt::Display| PngError {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    crate::analysis::plots::render::register_font();
    let buf = super::render(snap, t, COLS, LINES);
    let size = (COLS as u32 * CW as u32, LINES as u32 * CH as u32);
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&rgb(Tui::Reset, false)).map_err(|e| fail(&e))?;
    for y in 0..LINES {
        for x in 0..COLS {
            let cell = &buf[(x, y)];
            let (px, py) = (x as i32 * CW, y as i32 * CH);
            let reversed = cell.modifier.contains(ratatui::style::Modifier::REVERSED);
            let (mut fg, mut bg) = (rgb(cell.fg, true), rgb(cell.bg, false));
            if reversed {
                std::mem::swap(&mut fg, &mut bg);
            }
            if cell.bg != Tui::Reset || reversed {
                root.draw(&Rectangle::new([(px, py), (px + CW, py + CH)], bg.filled()))
                    .map_err(|e| fail(&e))?;
            }
            let Some(ch) = cell.symbol().chars().next() else {
                continue;
            };
            if ch == ' ' {
                continue;
            }
            glyph(&root, ch, px, py, fg).map_err(|e| fail(&e))?;
        }
    }
    root.present().map_err(|e| fail(&e))
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;
type DrawResult<'a> =
    Result<(), DrawingAreaErrorKind<<BitMapBackend<'a> as DrawingBackend>::ErrorType>>;

/// One character: box drawing as lines, braille as dots, the rest as text.
fn glyph<'a>(root: &Area<'a>, ch: char, px: i32, py: i32, fg: RGBColor) -> DrawResult<'a> {
    let (mx, my) = (px + CW / 2, py + CH / 2);
    let line = |a: (i32, i32), b: (i32, i32)| PathElement::new(vec![a, b], fg.stroke_width(1));
    let (left, right, up, down) = match ch {
        '─' | '━' => (true, true, false, false),
        '│' | '┃' => (false, false, true, true),
        '┌' | '╭' => (false, true, false, true),
        '┐' | '╮' => (true, false, false, true),
        '└' | '╰' => (false, true, true, false),
        '┘' | '╯' => (true, false, true, false),
        '├' => (false, true, true, true),
        '┤' => (true, false, true, true),
        '┬' => (true, true, false, true),
        '┴' => (true, true, true, false),
        '┼' => (true, true, true, true),
        '⠀'..='⣿' => return braille(root, ch as u32 - 0x2800, px, py, fg),
        _ => {
            let style = ("sans-serif", 14).into_font().color(&fg);
            return root.draw(&Text::new(ch.to_string(), (px, py + 2), style));
        }
    };
    if left {
        root.draw(&line((px, my), (mx, my)))?;
    }
    if right {
        root.draw(&line((mx, my), (px + CW, my)))?;
    }
    if up {
        root.draw(&line((mx, py), (mx, my)))?;
    }
    if down {
        root.draw(&line((mx, my), (mx, py + CH)))?;
    }
    Ok(())
}

/// Braille cell: bits 0–2 and 6 the left column top to bottom, 3–5 and 7 the right.
fn braille<'a>(root: &Area<'a>, bits: u32, px: i32, py: i32, fg: RGBColor) -> DrawResult<'a> {
    const DOTS: [(i32, i32); 8] = [
        (0, 0),
        (0, 1),
        (0, 2),
        (1, 0),
        (1, 1),
        (1, 2),
        (0, 3),
        (1, 3),
    ];
    for (i, (c, r)) in DOTS.iter().enumerate() {
        if bits & (1 << i) != 0 {
            let (x, y) = (px + 2 + c * 4, py + 2 + r * 4);
            root.draw(&Rectangle::new([(x, y), (x + 2, y + 2)], fg.filled()))?;
        }
    }
    Ok(())
}
