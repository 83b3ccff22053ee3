//! The polite stops a node answers: SIGINT (Ctrl-C), SIGTERM (what systemd, `docker stop`
//! and `kill` send) and SIGHUP (the terminal closed). Each ends a run the same way: the
//! simulation stops, the bag gets its footer, the process exits 0. SIGKILL cannot be
//! caught; `bag recover` rebuilds what such a run left.

/// Waits for the first of SIGINT, SIGTERM and SIGHUP and returns its name.
///
/// The handlers are installed when this is first polled: await it (or poll it once) before
/// the run starts work worth finishing.
pub async fn polite_stop() -> &'static str {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{signal, Signal, SignalKind};
        async fn next(signal: &mut Option<Signal>) {
            match signal {
                Some(s) => {
                    s.recv().await;
                }
                None => std::future::pending().await,
            }
        }
        let install = |kind: SignalKind, name: &str| {
            signal(kind)
                .map_err(|e| tracing::warn!("cannot catch {name}: {e}"))
                .ok()
        };
        let mut term = install(SignalKind::terminate(), "SIGTERM");
        let mut hup = install(SignalKind::hangup(), "SIGHUP");
        tokio::select! {
            _ = tokio::signal::ctrl_c() => "SIGINT",
            _ = next(&mut term) => "SIGTERM",
            _ = next(&mut hup) => "SIGHUP",
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
        "Ctrl-C"
    }
}
