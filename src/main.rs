//! The `strahler` binary: natively the command line (no subcommand opens the app window);
//! on wasm32 the web entry point that Trunk builds.

#[cfg(not(target_arch = "wasm32"))]
fn main() -> std::process::ExitCode {
    use clap::Parser;
    use strahler::app::{Automation, StrahlerApp, wgpu_options};

    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = strahler::cli::Cli::parse();
    if let Some(command) = cli.command {
        return strahler::cli::run(command);
    }
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("Strahler")
            .with_inner_size([1280.0, 800.0]),
        wgpu_options: wgpu_options(),
        ..Default::default()
    };
    let result = eframe::run_native(
        "Strahler",
        options,
        Box::new(|cc| Ok(Box::new(StrahlerApp::new(cc, Automation::default())))),
    );
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: could not open the Strahler window: {err}");
            std::process::ExitCode::FAILURE
        }
    }
}

#[cfg(target_arch = "wasm32")]
fn main() {
    strahler::web::start();
}
