//! Print the documented `telemetry.h5` layout as the README's Markdown table.
fn main() {
    print!("{}", taiji::telemetry::layout::markdown_table());
}
