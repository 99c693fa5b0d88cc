//! A flag set by the first SIGINT or SIGTERM, for a client that runs until stopped
//! (`crossym record`) and checks the flag between its own steps.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A flag that the first SIGINT or SIGTERM sets. The handlers are installed before this
/// returns (a signal right after is not lost); a helper thread with a one-thread tokio
/// runtime waits for them.
pub fn stop_on_signals() -> std::io::Result<Arc<AtomicBool>> {
    use tokio::signal::unix::{signal, SignalKind};
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    let (mut int, mut term) = rt.block_on(async {
        Ok::<_, std::io::Error>((
            signal(SignalKind::interrupt())?,
            signal(SignalKind::terminate())?,
        ))
    })?;
    let flag = Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    std::thread::Builder::new()
        .name("crossym-signals".into())
        .spawn(move || {
            rt.block_on(async move {
                tokio::select! {
                    _ = int.recv() => {}
                    _ = term.recv() => {}
                }
                set.store(true, Ordering::Relaxed);
            })
        })?;
    Ok(flag)
}
