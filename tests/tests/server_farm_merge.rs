//! The merge of a split job across worker processes (docs/farm.md, worker/shard.rs): the worker
//! that merges sums the shards it finished from its memory and reads the others' files. Here a
//! worker dies after finishing some shards, one of its files is then damaged on disk, and the
//! worker that takes the job over finds it unusable at the merge, renders that shard again and
//! ends the job with exactly its samples and the image one worker renders of it whole.

use std::path::Path;
use std::time::{Duration, Instant};

use candela_tests::database::{run_on, Backend};
use candela_tests::farm::{rel_mse_to_whole, shard_files, shards, spp, Worker};
use candela_tests::scratch;
use candela_tests::server::Server;
use serde_json::json;

const T: Duration = Duration::from_secs(180);

#[test]
fn a_shard_file_unusable_at_the_merge_is_rendered_again() {
    run_on(
        Backend::Postgres,
        a_shard_file_unusable_at_the_merge_is_rendered_again_on_postgres,
    )
}

/// Flips bytes in the middle of `path` (its length unchanged): its checksum no longer holds.
fn damage(path: &Path) {
    let mut bytes = std::fs::read(path).unwrap();
    let mid = bytes.len() / 2;
    for b in &mut bytes[mid..mid + 64] {
        *b ^= 0x5a;
    }
    std::fs::write(path, bytes).unwrap();
}

fn a_shard_file_unusable_at_the_merge_is_rendered_again_on_postgres() {
    let dir = scratch("server_farm_merge_unusable");
    let data = dir.join("data");
    let api = Server::start(&data, &["--workers", "0"]);
    let split = ["--shard-spp", "20"];
    // Step 1: w1 renders shards of a job of five; killed once one is done (before the job ends).
    let body = json!({"scene_name": "cornell", "spp": 100, "width": 16, "height": 16,
                      "seed": 9});
    let id = api.submit(&body)["id"].as_i64().unwrap();
    let mut w1 = Worker::start_with(&data, "w1", "2", &split);
    let deadline = Instant::now() + T;
    let done_shard = loop {
        if let Some(r) = shards(&data, id).iter().find(|r| r.1) {
            break r.0;
        }
        assert!(Instant::now() < deadline, "{}", w1.log());
        std::thread::sleep(Duration::from_millis(10));
    };
    w1.kill9();
    assert_ne!(
        api.job(id)["state"],
        "done",
        "the job ended before the kill"
    );
    // Step 2: that shard's file is damaged; w2 takes the job over (w1's leases expire), reads
    // w1's files at the merge, renders the damaged one again and finishes.
    damage(&data.join(format!("jobs/{id}/shard-{done_shard}.bin")));
    let w2 = Worker::start_with(&data, "w2", "2", &split);
    let done = api.wait_job(id, T, |j| {
        matches!(j["state"].as_str(), Some("done" | "failed"))
    });
    assert_eq!(done["state"], "done", "{done}\n{}", w2.log());
    assert_eq!(spp(&done), 100, "{done}");
    assert_eq!(done["stats"]["spp"], 100, "{done}");
    let again = format!("job={id} shard={done_shard}");
    let unusable = w2
        .log()
        .lines()
        .any(|l| l.contains("checkpoint is unusable; rendering it again") && l.contains(&again));
    assert!(unusable, "{}", w2.log());
    let rows = shards(&data, id);
    assert!(rows.iter().all(|r| r.1 && r.3 == 20), "{rows:?}");
    assert_eq!(shard_files(&data, id), 0, "{}", w2.log());
    // Step 3: the same job rendered whole by a worker that splits nothing: the same image.
    drop(w2);
    let e = rel_mse_to_whole(&api, &data, &body, id);
    assert!(
        e < 1e-8,
        "split (a shard rendered again) vs whole relMSE {e}"
    );
}
